"""Finding plugins: the pluggy manager, built on first use from the ``postproc`` entry points.

Plugins load only from installed entry points, never from a path named in a measurement
or model file.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import pluggy

from . import hookspecs
from .compensator import Compensator
from .diagnostics import InternalError, OptionError, PluginError
from .measurements.registry import MeasurementReader

GROUP = "postproc"


@dataclass(frozen=True)
class Installed:
    cls: type[Compensator]
    version: str
    distribution: str


@functools.lru_cache(maxsize=1)
def manager() -> pluggy.PluginManager:
    pm = pluggy.PluginManager(GROUP)
    pm.add_hookspecs(hookspecs)
    try:
        pm.load_setuptools_entrypoints(GROUP)
    except Exception as exc:  # a broken plugin must not take the tool down without a word
        raise PluginError("entry point", f"a plugin failed to load: {exc}") from None
    pm.check_pending()
    return pm


def compensators() -> dict[str, Installed]:
    """Every installed compensator by name, with the version of its distribution."""
    pm = manager()
    versions = {id(plugin): (dist.version, dist.project_name) for plugin, dist in pm.list_plugin_distinfo()}
    found: dict[str, Installed] = {}
    for impl in pm.hook.postproc_compensators.get_hookimpls():
        version, distribution = versions.get(id(impl.plugin), ("?", "?"))
        for cls in impl.function() or ():
            if not (isinstance(cls, type) and issubclass(cls, Compensator) and cls.name):
                raise PluginError(impl.plugin_name, f"postproc_compensators returned {cls!r}, not a named Compensator class")
            if cls.name in found:
                raise InternalError(f"two plugins provide a compensator named {cls.name!r}")
            found[cls.name] = Installed(cls, version, distribution)
    return found


def select(names: list[str]) -> list[Installed]:
    """The compensators named by ``--plugin``, in that order."""
    installed = compensators()
    chosen = []
    for name in names:
        if name not in installed:
            known = ", ".join(sorted(installed)) or "none"
            raise OptionError(f"--plugin {name}: no compensator of that name is installed (installed: {known})")
        if any(item.cls.name == name for item in chosen):
            raise OptionError(f"--plugin {name} given twice")
        chosen.append(installed[name])
    return chosen


def readers() -> list[MeasurementReader]:
    """Measurement readers in pluggy's order of the hook's implementations: ``tryfirst`` ones,
    then the unmarked ones (the last registered first), then ``trylast`` ones, which the
    built-in readers are (docs/hooks.md). Each implementation is called here, not through the
    hook, so that a reader that is not one is refused naming its plugin; pluggy calls the
    implementations in the reverse of ``get_hookimpls()``, the order kept here."""
    found: list[MeasurementReader] = []
    for impl in reversed(manager().hook.postproc_measurement_readers.get_hookimpls()):
        for reader in impl.function() or ():
            if not isinstance(reader, MeasurementReader):
                raise PluginError(impl.plugin_name, f"postproc_measurement_readers returned {reader!r}")
            found.append(reader)
    return found
