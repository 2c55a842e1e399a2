"""postproc: rewrite FANUC lathe part programs so that the next part is cut right.

The Python API (``compensate_text``, ``Pipeline``) is loaded on first use, so that importing
postproc stays as quick as the command line needs.
"""

__version__ = "0.1.0"
__all__ = ["compensate_text", "Pipeline", "__version__"]


def __getattr__(name: str):
    if name in ("compensate_text", "Pipeline"):
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'postproc' has no attribute {name!r}")
