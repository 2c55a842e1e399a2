"""The documented public path of the plugin hooks (docs/hooks.md): a plugin writes
``from postproc.hookspecs import hookimpl``. The hooks live in :mod:`postproc.compensate.hookspecs`;
this module only re-exports the markers."""

from .compensate.hookspecs import hookimpl, hookspec

__all__ = ["hookimpl", "hookspec"]
