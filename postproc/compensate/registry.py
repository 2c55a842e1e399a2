"""Finding plugins: the pluggy manager, built on first use from the ``postproc`` entry points.

Plugins load only from installed entry points, never from a path named in a measurement
or model file.

A run loads only what it uses: the entry points' names are read from the installed
metadata without importing anything, and a run that names only compensators this
distribution provides loads those and the other distributions' plugins, not the rest of
its own (a small job starts in about the time Python and numpy take). Each of this
distribution's entry points is named after the compensator it provides, so a loaded
plugin whose compensator takes the name of one left unloaded is a clash: then everything
loads and the clash is reported as a full load reports it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import pluggy

from . import hookspecs
from .compensator import Compensator
from ..diagnostics import InternalError, OptionError, PluginError
from ..measure.readers.registry import MeasurementReader

GROUP = "postproc"
OWN = "postproc"  #: the distribution whose entry points load only when selected


@dataclass(frozen=True)
class Installed:
    cls: type[Compensator]
    version: str
    distribution: str


@functools.lru_cache(maxsize=1)
def _bare() -> pluggy.PluginManager:
    """The one manager, its hook specifications added and no plugin loaded yet."""
    pm = pluggy.PluginManager(GROUP)
    pm.add_hookspecs(hookspecs)
    return pm


def _load(name: str | None = None) -> pluggy.PluginManager:
    """Load the entry points of that name (None: all) not loaded yet."""
    pm = _bare()
    try:
        pm.load_setuptools_entrypoints(GROUP, name)
    except Exception as exc:  # a broken plugin must not take the tool down without a word
        raise PluginError("entry point", f"a plugin failed to load: {exc}") from None
    pm.check_pending()
    return pm


@functools.lru_cache(maxsize=1)
def manager() -> pluggy.PluginManager:
    """The manager with every installed plugin loaded."""
    return _load()


def _entry_points() -> list[tuple[str, str]]:
    """(name, distribution) of each entry point of the group, read from the installed metadata
    without importing any plugin."""
    from importlib.metadata import entry_points

    return [(point.name, point.dist.name if point.dist is not None else "") for point in entry_points(group=GROUP)]


def compensators() -> dict[str, Installed]:
    """Every installed compensator by name, with the version of its distribution."""
    return _found(manager())


def _found(pm: pluggy.PluginManager) -> dict[str, Installed]:
    """The compensators of the plugins loaded so far, by name; two of one name are an error."""
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
    installed = _selected(names)
    chosen = []
    for name in names:
        if name not in installed:
            known = ", ".join(sorted(installed)) or "none"
            raise OptionError(f"--plugin {name}: no compensator of that name is installed (installed: {known})")
        if any(item.cls.name == name for item in chosen):
            raise OptionError(f"--plugin {name} given twice")
        chosen.append(installed[name])
    return chosen


def _selected(names: list[str]) -> dict[str, Installed]:
    """The compensators of the plugins a run needs: the named ones of this distribution and
    every other distribution's (their names are known only once loaded); all of them when a
    name is not one of this distribution's entry points, or a loaded compensator takes the
    name of one left unloaded."""
    points = _entry_points()
    own = {name for name, distribution in points if distribution == OWN}
    if manager.cache_info().currsize or not set(names) <= own:
        return compensators()
    for name in dict.fromkeys(names):
        _load(name)
    for name, distribution in points:
        if distribution != OWN:
            _load(name)
    pm = _bare()
    found = _found(pm)
    if any(name in own and not pm.has_plugin(name) for name in found):
        return compensators()
    return found


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
