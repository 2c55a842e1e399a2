"""The hooks a postproc plugin may implement. Hooks are for discovery only.

A plugin is a module (or object) registered under the ``postproc`` entry-point group.
The built-in compensators and measurement readers are registered exactly so. Hooks tell
the core *what* a plugin offers; the core then decides *when* to use it: compensators run
in the order of the ``--plugin`` options, never in pluggy's registration order, and they
return edits as data (a displacement along each move), never change blocks themselves.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import pluggy

if TYPE_CHECKING:
    from .compensator import Compensator
    from ..measure.readers.registry import MeasurementReader

hookspec = pluggy.HookspecMarker("postproc")
hookimpl = pluggy.HookimplMarker("postproc")


@hookspec
def postproc_compensators() -> list[type[Compensator]]:
    """The compensator classes this plugin provides.

    Each class is a :class:`postproc.compensate.compensator.Compensator` with a unique ``name`` (the
    value of ``--plugin``), the measurement kinds it ``takes``, the ``options`` it declares
    and a class docstring that is its user documentation (its first line is the summary
    ``postproc plugins`` shows).

    :returns: a list of classes; every implementation's lists are joined.
    """


@hookspec
def postproc_measurement_readers() -> list[MeasurementReader]:
    """Readers of measurement files, for formats an instrument exports.

    A :class:`postproc.measure.readers.registry.MeasurementReader` names the ``kind`` it reads
    (``ballbar``, ``probe`` or ``calibration``), says whether it ``accepts`` a file (by its
    first bytes, not only its name) and ``read``s it into the same objects the built-in
    readers make. The first reader that accepts a file reads it, in pluggy's order of the
    implementations: ``@hookimpl(tryfirst=True)`` ones first, then unmarked ones (the last
    registered first), then ``trylast`` ones. The built-in readers of docs/formats.md §3-§6 are
    registered through this hook too, ``trylast``, and accept every file: a shop's reader
    comes before them unless it is ``trylast`` itself.

    :returns: a list of readers; every implementation's lists are joined.
    """
