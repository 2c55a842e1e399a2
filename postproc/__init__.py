"""postproc: rewrite FANUC lathe part programs so that the next part is cut right."""

__version__ = "0.1.0"
