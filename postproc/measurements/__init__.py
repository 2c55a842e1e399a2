"""Measurements: ballbar traces, probe points and probe calibrations (formats.md)."""
