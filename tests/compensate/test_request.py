"""What the user asked for (postproc/compensate/request.py): one value, built by keyword."""

from __future__ import annotations

import dataclasses

import pytest

from postproc.compensate.request import Request


def test_a_request_is_built_by_keyword_only():
    """Thirteen fields, several of one type (lists of paths, optional numbers): by position, a
    shifted argument would put a probe file among the ballbar traces without a word."""
    with pytest.raises(TypeError):
        Request(["parametric"], ["ccw.csv"])  # type: ignore[misc]
    request = Request(plugins=["parametric"], ballbar=["ccw.csv"], tolerance=0.002)
    assert (request.plugins, request.ballbar, request.probe, request.tolerance) == (["parametric"], ["ccw.csv"], [], 0.002)
    assert all(field.kw_only for field in dataclasses.fields(Request))
