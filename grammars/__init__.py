"""The FANUC grammar, shipped inside the package as ``postproc.grammars``."""
