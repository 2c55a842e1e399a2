"""``postproc report``: one self-contained HTML file on the measurements, the fitted model
and what compensation should do to a program.

One job per module:

- :mod:`.document`: what a report is made of (sections, text, tables, images), as plain data;
  every string in it is plain text, never markup;
- :mod:`.run`: everything the report draws on, gathered once: the compensators fitted as
  ``compensate`` fits them, the measurements read and analysed, the program compensated;
- :mod:`.sections`: what goes in: the measurements, the ISO 230-4 figures and the fitted
  models with their uncertainty, the predicted profile before and after compensation, the
  four figures (docs/methods.md §12) of each, and the provenance;
- :mod:`.fitted`: a compensator's ``report()`` dict as tables and images, whatever it holds;
- :mod:`.prediction`: the predicted profile, on the virtual lathe (:mod:`postproc.simulator`);
- :mod:`.provenance`: versions, inputs with their SHA-256, machine profile, options, time;
- :mod:`.charts`: the figures, rendered to PNG in memory (matplotlib, imported on use);
- :mod:`.html`: the template: escapes every string, embeds the images as ``data:`` URIs and
  the style sheet inline, so the file needs nothing but itself.
"""
