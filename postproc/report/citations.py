"""The citations a report shows, resolved for its reader.

Text in a report (a compensator's documentation, a note, a warning) cites the project's pages
as all of postproc does, ``docs/methods.md §7.2`` (docs/methods.md explains the convention).
The report is one file read anywhere, without the pages, so it ends with a *References*
section: every page and section its text cites, with the section's title, and where the
page is (the ``docs`` folder of postproc's source: the repository, or the source
distribution). Numbers of the source dissertation (eq. 6.11, Table 6.7) are named as the
source's; docs/methods.md keeps an index of where each is discussed.

:data:`TITLES` holds the pages' numbered headings (tests/report/test_report.py holds it to the pages
and requires a title for every section a compensator's documentation or the report cites).
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from .document import Section, Table, Text

WHERE = "the docs folder of postproc's source (its repository or source distribution)"
SOURCE = ("A. H. Chen, Integrated Inspection for Precision Part Production, PhD dissertation, Georgia Institute "
          "of Technology, 2006 (\"the source\")")
PAGES = {"methods.md": "Methods", "formats.md": "File formats and the command line", "hooks.md": "Hook reference",
         "user-guide.md": "postproc user guide", "reference.md": "Reference",
         "cam.md": "postproc after a CAM post-processor",
         "controller-compensation.md": "What the control already compensates, and what postproc adds"}

#: (page, section) -> the section's heading
TITLES = {
    ("methods.md", "1"): "The task and the machine",
    ("methods.md", "2"): "Coordinates and signs",
    ("methods.md", "3"): "Ballbar traces",
    ("methods.md", "3.1"): "The test and a raw trace",
    ("methods.md", "3.2"): "The set-up centre",
    ("methods.md", "3.3"): "ISO 230-4 figures",
    ("methods.md", "3.4"): "The parametric diagnosis",
    ("methods.md", "4"): "Inversion about the nominal (ballbar-inverse)",
    ("methods.md", "4.1"): "On a circle",
    ("methods.md", "4.2"): "Any profile",
    ("methods.md", "4.3"): "Implementing the new path",
    ("methods.md", "5"): "Iterative and selective inversion (iterative)",
    ("methods.md", "5.1"): "The source's loop on the ballbar (simulate ballbar --program)",
    ("methods.md", "6"): "A trace on an arc of another radius",
    ("methods.md", "7"): "Per-axis error functions",
    ("methods.md", "7.1"): "Effective angle (effective-angle)",
    ("methods.md", "7.2"): "Parametric (parametric)",
    ("methods.md", "7.3"): "Beyond the test circle",
    ("methods.md", "7.4"): "Effective angle: the standing axis, and a predicted result",
    ("methods.md", "8"): "The virtual lathe (postproc simulate)",
    ("methods.md", "8.1"): "The sample machine against the source's",
    ("methods.md", "9"): "On-machine probing",
    ("methods.md", "9.1"): "The touched point",
    ("methods.md", "9.2"): "Calibrating the pretravel on a sphere",
    ("methods.md", "9.2.1"): "Finding the artifact (artifact-program, artifact-find)",
    ("methods.md", "9.3"): "The stability check",
    ("methods.md", "9.4"): "Deviations from any profile",
    ("methods.md", "9.5"): "The nub and stray touches",
    ("methods.md", "9.6"): "Compensating from the probed pass (omp-feedback)",
    ("methods.md", "9.7"): "The probing program and its printout (probe-program, probe-import)",
    ("methods.md", "9.8"): "The verdict (inspect)",
    ("methods.md", "9.9"): "Probe points per feature, never across a corner",
    ("methods.md", "10"): "The tool-setting error from the part (tool-offset)",
    ("methods.md", "10.1"): "The tool-setting error as a wear offset",
    ("methods.md", "11"): "Error budget (postproc budget)",
    ("methods.md", "12"): "The four figures",
    ("methods.md", "13"): "From a corrected path to blocks: the segmenter",
    ("methods.md", "14"): "Writing the corrected program",
    ("methods.md", "14.1"): "G71/G72 contours: the one-way rule",
    ("methods.md", "15"): "Partial-arc ballbar tests",
    ("methods.md", "15.1"): "The captured arc",
    ("methods.md", "15.2"): "The set-up centre, fitted with the model",
    ("methods.md", "15.3"): "Uncertainties that grow as the arc shrinks",
    ("methods.md", "15.4"): "Sanity checks",
    ("methods.md", "15.5"): "Several tests in one fit",
    ("methods.md", "15.6"): "Minimum evidence per compensator",
    ("methods.md", "16"): "An error map over the plane (error-map)",
    ("methods.md", "16.1"): "The map and its fit",
    ("methods.md", "16.2"): "What a ballbar can and cannot see",
    ("methods.md", "16.3"): "A cut part's deviations pin the rest (--probe)",
    ("methods.md", "16.4"): "Measured here",
    ("formats.md", "1"): "Conventions",
    ("formats.md", "2"): "Part programs",
    ("formats.md", "3"): "Measurement files: the common shape",
    ("formats.md", "4"): "Ballbar trace",
    ("formats.md", "5"): "Probe points",
    ("formats.md", "6"): "Probe calibration on an artifact",
    ("formats.md", "7"): "The command line",
    ("formats.md", "7.1"): "Input, output and files",
    ("formats.md", "7.2"): "Messages",
    ("formats.md", "7.3"): "Exit codes",
    ("formats.md", "7.4"): "Options before the command",
    ("formats.md", "8"): "Commands",
    ("formats.md", "8.1"): "postproc compensate",
    ("formats.md", "8.2"): "postproc fit",
    ("formats.md", "8.3"): "postproc check",
    ("formats.md", "8.4"): "postproc path",
    ("formats.md", "8.5"): "postproc ballbar",
    ("formats.md", "8.6"): "postproc plugins",
    ("formats.md", "8.7"): "postproc report",
    ("formats.md", "8.8"): "postproc probe-program",
    ("formats.md", "8.9"): "postproc probe-import",
    ("formats.md", "8.10"): "postproc inspect",
    ("formats.md", "8.11"): "postproc budget",
    ("formats.md", "8.12"): "postproc simulate",
    ("formats.md", "8.13"): "postproc profile show",
    ("formats.md", "8.14"): "postproc import-trace",
    ("formats.md", "8.15"): "postproc artifact-program",
    ("formats.md", "8.16"): "postproc artifact-find",
    ("formats.md", "8.17"): "postproc profile init",
    ("formats.md", "9"): "Compensators: what each is given and what it touches",
    ("formats.md", "9.1"): "Rules common to all",
    ("formats.md", "9.2"): "ballbar-inverse",
    ("formats.md", "9.3"): "iterative",
    ("formats.md", "9.4"): "parametric",
    ("formats.md", "9.5"): "effective-angle",
    ("formats.md", "9.6"): "omp-feedback",
    ("formats.md", "9.7"): "tool-offset",
    ("formats.md", "9.8"): "error-map",
    ("formats.md", "10"): "Tool path CSV",
    ("formats.md", "11"): "postproc ballbar --json",
    ("formats.md", "12"): "Compensated program and its provenance block",
    ("formats.md", "13"): "Model file",
    ("formats.md", "14"): "Compensation report (compensate --report FILE)",
    ("formats.md", "15"): "Machine profile",
    ("formats.md", "16"): "Probing printout",
    ("formats.md", "17"): "Surface file",
    ("formats.md", "18"): "Error budget file",
    ("formats.md", "19"): "Project file",
}

CITED = re.compile(r"(?<![\w/.-])(?:docs/)?(?P<page>[\w-]+\.md)\b(?P<sections>(?:(?:[\s,;]|and\b|or\b|to\b)*-?\s*§\s*"
                   r"\d+(?:\.\d+)*)*)")
NUMBER = re.compile(r"(-?)\s*§\s*(\d+(?:\.\d+)*)")
SOURCE_REF = re.compile(r"\b(eqs?\.|equations?|tables?|figures?|fig\.|sections?|chapters?)\s+(\d+\.\d+(?:\.\d+)*|\d+)"
                        r"((?:\s*(?:-|,|and|to)\s*\d+(?:\.\d+)*)*)", re.I)


def citations(text: str) -> list[tuple[str, str | None]]:
    """(page, section or None) of every page cited in ``text``, in order; a range
    (``formats.md §3-§6``) is every section from the first to the last."""
    found = []
    for match in CITED.finditer(text):
        page = match.group("page")
        numbers = NUMBER.findall(match.group("sections"))
        if not numbers:
            found.append((page, None))
        previous = None
        for dash, number in numbers:
            if dash and previous is not None and "." not in previous + number:
                found += [(page, str(n)) for n in range(int(previous) + 1, int(number))]
            found.append((page, number))
            previous = number
    return found


def source_numbers(text: str) -> list[str]:
    """The source's numbers cited in ``text`` as written: ``eq. 6.12-6.13``, ``Table 6.7``.
    A section of the source is cited by a dotted number (``section 6.3``), never ``§``."""
    return [" ".join(match.group(0).split()) for match in SOURCE_REF.finditer(text)
            if match.group(1).lower().startswith(("eq", "table", "fig")) or "." in match.group(2)]


def title(page: str, number: str | None) -> str:
    if number is None:
        return PAGES.get(page, "")
    return TITLES.get((page, number), "")


def section(texts: Iterable[str]) -> Section | None:
    """The References section for the report's texts, or None when they cite nothing."""
    pages: dict[tuple[str, str | None], None] = {}
    source: dict[str, None] = {}
    for text in texts:
        pages.update(dict.fromkeys(citations(text)))
        source.update(dict.fromkeys(source_numbers(text)))
    if not pages and not source:
        return None
    parts = []
    if pages:
        ordered = sorted(pages, key=lambda cited: (cited[0], _order(cited[1])))
        rows = tuple((f"docs/{page}" + (f" §{number}" if number else ""), title(page, number) or "(no title known)")
                     for page, number in ordered)
        parts.append(Text(f"The pages cited above are postproc's own, in {WHERE}; a section is cited by its "
                          "number, which never changes."))
        parts.append(Table(("cited", "section"), rows, "postproc's pages", key="references", numeric=False))
    if source:
        parts.append(Text(f"Cited by its own numbers ({', '.join(source)}): {SOURCE}. docs/methods.md says where each "
                          "of its numbers is discussed (its index of the source's numbers) and how postproc departs "
                          "from it."))
    return Section("references", "References", parts)


def _order(number: str | None) -> tuple[int, ...]:
    return tuple(int(n) for n in number.split(".")) if number else ()
