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

Reading the metadata through :mod:`importlib.metadata` costs a small job some 25 ms, a
fifth of numpy's import (it imports the e-mail parser, zip and CSV modules), so the
directories on ``sys.path`` are looked through first, as that module looks through them,
reading only each distribution's ``entry_points.txt``: when no other distribution declares
a ``postproc`` entry point, this distribution's named ones load directly. Anything that scan
cannot vouch for (another distribution's ``postproc`` entry point, a zip or egg on the path,
a finder of distributions other than Python's own) goes the way of :mod:`importlib.metadata`
and pluggy, so that a third-party plugin is loaded, and a clash caught, as before.
"""

from __future__ import annotations

import functools
import os
import re
import sys
import dataclasses
from contextlib import redirect_stdout
from dataclasses import dataclass
from typing import TYPE_CHECKING

import pluggy

from . import hookspecs
from .compensator import Compensator
from ..diagnostics import OptionError, PluginError

if TYPE_CHECKING:
    from ..measure.readers.registry import MeasurementReader

GROUP = "postproc"
OWN = "postproc"  #: the distribution whose entry points load only when selected
#: an entry point's value, as importlib.metadata.EntryPoint reads it: module, attributes, extras
_VALUE = r"(?P<module>[\w.]+)\s*(:\s*(?P<attr>[\w.]+)\s*)?((?P<extras>\[.*\])\s*)?$"
_loaded_own: dict[int, tuple[str, str]] = {}  # id(plugin): (version, distribution) of those loaded directly


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
        with redirect_stdout(sys.stderr):  # what a plugin prints on import goes to stderr: stdout carries the output alone
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
    versions.update(_loaded_own)
    found: dict[str, Installed] = {}
    provider: dict[str, str] = {}
    for impl in pm.hook.postproc_compensators.get_hookimpls():
        version, distribution = versions.get(id(impl.plugin), ("?", "?"))
        for cls in _offered(impl, "postproc_compensators"):
            if not (isinstance(cls, type) and issubclass(cls, Compensator) and isinstance(cls.name, str) and cls.name):
                raise PluginError(impl.plugin_name, f"postproc_compensators returned {cls!r}, not a named Compensator class")
            _check_names(impl.plugin_name, cls)
            if cls.name in found:
                raise PluginError(impl.plugin_name, f"two plugins provide a compensator named {cls.name!r} (this one "
                                                    f"and {provider[cls.name]!r}); uninstall or rename one of them")
            found[cls.name] = Installed(cls, version, distribution)
            provider[cls.name] = impl.plugin_name
    return found


#: a compensator's name and its options' keys: what --plugin NAME and --option NAME.KEY=VALUE can spell
_NAME = re.compile(r"[a-z0-9][a-z0-9_-]*")


def _check_names(plugin: str, cls: type[Compensator]) -> None:
    """Refuse a compensator the command line could not name, or whose options it could not tell apart."""
    if not _NAME.fullmatch(cls.name):
        raise PluginError(plugin, f"a compensator named {cls.name!r}: a name is lower-case letters, digits, '-' and "
                                  "'_' (it is spelt on the command line, and in --option NAME.KEY=VALUE)")
    keys = [getattr(option, "key", None) for option in cls.options]
    for key in keys:
        if not (isinstance(key, str) and _NAME.fullmatch(key)):
            raise PluginError(plugin, f"compensator {cls.name!r} declares an option {key!r}: a key is lower-case "
                                      "letters, digits, '-' and '_'")
        if keys.count(key) > 1:
            raise PluginError(plugin, f"compensator {cls.name!r} declares the option {key!r} twice")


def _offered(impl, hook: str) -> list:
    """What one plugin's hook implementation returns; a hook that fails is its plugin's fault."""
    try:
        with redirect_stdout(sys.stderr):  # what a plugin prints goes to stderr: stdout carries the output alone
            return list(impl.function() or ())
    except Exception as exc:
        raise PluginError(impl.plugin_name, f"{hook} failed: {exc.__class__.__name__}: {exc}") from None


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
    alone = _own_alone()
    points = _entry_points() if alone is None else [(name, OWN) for name in alone.points]
    own = {name for name, distribution in points if distribution == OWN}
    if manager.cache_info().currsize or not set(names) <= own:
        return compensators()
    for name in dict.fromkeys(names):
        if alone is None:
            _load(name)
        else:
            _load_own(alone, name)
    for name, distribution in points:
        if distribution != OWN:
            _load(name)
    pm = _bare()
    found = _found(pm)
    if any(name in own and not pm.has_plugin(name) for name in found):
        return compensators()
    return found


class _Own:
    """This distribution's entry points of the group, when it is the only one to declare any
    (a plain class: a dataclass would cost the start of every run more than it saves)."""

    __slots__ = ("points", "version", "distribution")

    def __init__(self, points: dict[str, str], version: str | None, distribution: str):
        self.points = points  #: name: value (``module:attribute``)
        self.version = version
        self.distribution = distribution  #: its name as its metadata spells it


def _own_alone() -> _Own | None:
    """This distribution's entry points, found by looking through the directories on
    ``sys.path`` as :mod:`importlib.metadata` does, when no other distribution declares an
    entry point of the group; None when one does, or when the path holds what only that
    module reads (a zip, an egg, distributions found by another finder)."""
    import importlib.machinery

    if any(hasattr(finder, "find_distributions") and finder is not importlib.machinery.PathFinder
           for finder in sys.meta_path):
        return None
    found = None
    for entry in sys.path:
        root = entry or "."
        if root.lower().endswith(".egg") or os.path.isfile(root):
            return None
        try:
            children = os.listdir(root)
        except OSError:
            continue
        for child in children:
            if not child.lower().endswith((".dist-info", ".egg-info")):
                continue
            info = os.path.join(root, child)
            try:
                with open(os.path.join(info, "entry_points.txt"), encoding="utf-8") as file:
                    text = file.read()
            except (FileNotFoundError, NotADirectoryError):
                continue
            except (OSError, UnicodeDecodeError):
                return None
            points = _group(text)  # every one: a file importlib.metadata would refuse is refused as before
            if points is None:
                return None
            if not points:
                continue
            name, version = _name_and_version(info)
            if name != OWN:
                return None
            if found is None:  # the first of this distribution on the path is the one that loads
                found = _Own(points, version, name)
    return found


def _group(text: str) -> dict[str, str] | None:
    """The entry points of the group in an ``entry_points.txt`` (the first of each name, the
    one that loads), read as importlib.metadata reads it: stripped lines, ``#`` comments,
    ``[group]`` sections, ``name = value``; None for a line it would refuse (no ``=``)."""
    points: dict[str, str] = {}
    section = None
    for line in map(str.strip, text.splitlines()):
        if not line or line.startswith("#"):
            continue
        if line.startswith("[") and line.endswith("]"):
            section = line.strip("[]")
            continue
        if section is None:
            continue
        name, equals, value = line.partition("=")
        if not equals:
            return None
        if section == GROUP:
            points.setdefault(name.strip(), value.strip())
    return points


def _name_and_version(info: str) -> tuple[str | None, str | None]:
    """The Name and Version headers of a distribution's metadata (METADATA, or PKG-INFO for an egg-info)."""
    headers: dict[str, str] = {}
    for file in ("METADATA", "PKG-INFO"):
        try:
            with open(os.path.join(info, file), encoding="utf-8") as lines:
                for line in lines:
                    if not line.strip():
                        break
                    key, colon, value = line.partition(":")
                    if colon:
                        headers.setdefault(key.strip().lower(), value.strip())
            break
        except (OSError, UnicodeDecodeError):
            continue
    return headers.get("name"), headers.get("version")


def _load_own(own: _Own, name: str) -> None:
    """Load one of this distribution's entry points as pluggy loads one (through
    ``EntryPoint.load``, whose steps and failures these are), without reading any other
    distribution's metadata."""
    import importlib

    pm = _bare()
    if pm.has_plugin(name) or pm.is_blocked(name):
        return
    try:
        match = re.match(_VALUE, own.points[name])
        with redirect_stdout(sys.stderr):  # as in _load
            module = importlib.import_module(match.group("module"))
        plugin = functools.reduce(getattr, filter(None, (match.group("attr") or "").split(".")), module)
        pm.register(plugin, name=name)
    except Exception as exc:  # a broken plugin must not take the tool down without a word
        raise PluginError("entry point", f"a plugin failed to load: {exc}") from None
    _loaded_own[id(plugin)] = (own.version, own.distribution)
    pm.check_pending()


def readers() -> list[MeasurementReader]:
    """Measurement readers in pluggy's order of the hook's implementations: ``tryfirst`` ones,
    then the unmarked ones (the last registered first), then ``trylast`` ones, which the
    built-in readers are (docs/hooks.md). Each implementation is called here, not through the
    hook, so that a reader that is not one is refused naming its plugin; pluggy calls the
    implementations in the reverse of ``get_hookimpls()``, the order kept here."""
    from ..measure.readers.registry import MeasurementReader  # not for a run that reads no measurement

    found: list[MeasurementReader] = []
    for impl in reversed(manager().hook.postproc_measurement_readers.get_hookimpls()):
        for reader in _offered(impl, "postproc_measurement_readers"):
            if not isinstance(reader, MeasurementReader):
                raise PluginError(impl.plugin_name, f"postproc_measurement_readers returned {reader!r}")
            found.append(dataclasses.replace(reader, plugin=impl.plugin_name))
    return found
