"""The documented public path of the compensator contract (docs/hooks.md): a shop plugin writes
``from postproc.compensator import Compensator, Option, Piece``. The contract lives in
:mod:`postproc.compensate.compensator`; this module only re-exports it, and loads no engine module."""

from .compensate.compensator import (MAX_UNCERTAINTY_MM, STOCK_MM, Compensator, Context, Measurements, Option, Piece,
                                     parse_options)

__all__ = ["Compensator", "Option", "Context", "Measurements", "Piece", "parse_options", "STOCK_MM", "MAX_UNCERTAINTY_MM"]
