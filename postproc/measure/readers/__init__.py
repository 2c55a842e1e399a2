"""Measurements: ballbar traces, probe points and probe calibrations (docs/formats.md §3-§6)."""
