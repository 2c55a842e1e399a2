"""The features of a profile (postproc.measure.features): lines and arcs between corners, and where to touch them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.diagnostics import SpreadError
from postproc.measure.features import MIN_TOUCHES, corner_room, features, owners, spread
from postproc.geometry import Arc, Line, Profile

# A shaft's outside, cut towards -Z, material towards the axis: chamfer, diameter in two blocks, a concave
# G02 fillet, a shoulder face, a convex G03 round, a diameter, a taper, a face.
SHAFT = Profile((
    Line(20.0, 0.0, 22.0, -2.0),
    Line(22.0, -2.0, 22.0, -8.0),
    Line(22.0, -8.0, 22.0, -12.0),
    Arc.through((22.0, -12.0), (27.0, -17.0), (27.0, -12.0), cw=True),
    Line(27.0, -17.0, 36.0, -17.0),
    Arc.through((36.0, -17.0), (40.0, -21.0), (36.0, -21.0), cw=False),
    Line(40.0, -21.0, 40.0, -45.0),
    Line(40.0, -45.0, 45.0, -50.0),
    Line(45.0, -50.0, 53.0, -50.0),
))
LINES = (7, 8, 9, 10, 11, 12, 13, 14, 15)
OUTWARD = 1.0  #: going -Z with the material towards the axis, the outward normal is the left one


def test_a_shaft_has_one_feature_per_line_or_arc_and_corners_where_the_tangent_turns():
    found = features(SHAFT, LINES)
    assert [f.describe() for f in found] == [
        "the taper on line 7", "the diameter on lines 8-9", "the G02 arc R5 on line 10", "the face on line 11",
        "the G03 arc R4 on line 12", "the diameter on line 13", "the taper on line 14", "the face on line 15"]
    assert [(f.first, f.stop) for f in found] == [(0, 1), (1, 3), (3, 4), (4, 5), (5, 6), (6, 7), (7, 8), (8, 9)]
    assert list(owners(found)) == [0, 1, 1, 2, 3, 4, 5, 6, 7]
    turns = [round(math.degrees(f.turn_out), 6) if f.turn_out is not None else None for f in found]
    assert [abs(t) if t is not None else None for t in turns] == [45.0, 0.0, 0.0, 0.0, 0.0, 45.0, 45.0, None]
    assert found[0].turn_in is None and found[0].s0 == 0.0 and found[-1].s1 == pytest.approx(SHAFT.length)


def test_moves_on_one_circle_are_one_arc():
    whole = Arc.through((10.0, 0.0), (0.0, 10.0), (0.0, 0.0), cw=True)
    halves = Profile((whole.part(0.0, 0.5), whole.part(0.5, 1.0), Line(0.0, 10.0, -5.0, 10.0)))
    assert [f.kind for f in features(halves)] == ["G02 arc", "face"]


def test_a_concave_corner_keeps_the_stylus_clear_a_convex_one_does_not():
    square = math.radians(90.0)
    assert corner_room(square, 1.0, 3.0, 1.0) == pytest.approx(1.02 * 3.25 + 0.001)
    assert corner_room(-square, 1.0, 3.0, 1.0) == 0.0  # the same turn with the material on the other side
    assert corner_room(math.radians(0.5), 1.0, 3.0, 1.0) == 0.0  # no corner
    assert corner_room(math.radians(45.0), 1.0, 3.0, 1.0) < corner_room(square, 1.0, 3.0, 1.0)
    assert corner_room(math.pi, 1.0, 3.0, 1.0) == math.inf


def test_touches_go_to_every_feature_clear_of_its_ends():
    found = features(SHAFT, LINES)
    placed = spread(found, 40, 0.5, outward_sign=OUTWARD, radius=3.0, clearance=1.0)
    assert sum(placed.counts) == 40 and min(placed.counts) >= MIN_TOUCHES
    for feature, count, (start, end) in zip(found, placed.counts, placed.insets):
        on = placed.s[(placed.s >= feature.s0) & (placed.s <= feature.s1)]
        assert len(on) == count
        assert on.min() >= feature.s0 + start - 1e-9 and on.max() <= feature.s1 - end + 1e-9
        assert start >= 0.5 and end >= 0.5
    # the taper and the face after it meet at a concave corner: the stylus needs more than the inset there
    assert placed.insets[-2][1] > 1.0 and placed.insets[-1][0] > 1.0
    assert np.all(np.diff(placed.s) > 0)


def test_a_feature_too_short_gets_no_touch_and_too_few_touches_are_refused():
    found = features(SHAFT, LINES)
    short = spread(found, 40, 1.5, outward_sign=OUTWARD, radius=3.0, clearance=1.0)
    assert short.counts[0] == 0  # the chamfer: 2.8 mm long, 1.5 mm kept at each end
    with pytest.raises(SpreadError) as caught:
        spread(found, 20, 0.5, outward_sign=OUTWARD, radius=3.0, clearance=1.0)
    assert caught.value.wanted == 24
    with pytest.raises(SpreadError, match="no feature has room") as nothing:
        spread(found, 40, 30.0)
    assert nothing.value.wanted is None


@st.composite
def chains(draw):
    """Connected lines and arcs, with collinear and co-circular repeats now and then."""
    segments, x, z, heading = [], 10.0, 0.0, -math.pi / 2
    for _ in range(draw(st.integers(1, 9))):
        kind = draw(st.sampled_from(["line", "line again", "arc", "arc again"]))
        if kind == "line again" and segments and isinstance(segments[-1], Line):
            kind = "again"
        elif kind == "arc again" and segments and isinstance(segments[-1], Arc):
            kind = "again"
        else:
            kind = kind.split()[0]
            heading += math.radians(draw(st.sampled_from([0.0, 20.0, -30.0, 45.0, 90.0, -90.0])))
        if kind == "again":
            last = segments[-1]
            nxt = Line(x, z, *(np.array([x, z]) + 3.0 * np.array(last.direction))) if isinstance(last, Line) else \
                Arc(last.xc, last.zc, last.end_radius, last.theta1, last.sweep)
        elif kind == "line":
            nxt = Line(x, z, x + 5.0 * math.cos(heading), z + 5.0 * math.sin(heading))
        else:
            radius, sign = draw(st.floats(2.0, 8.0)), draw(st.sampled_from([1.0, -1.0]))
            # the centre to the side the arc turns to, so that it leaves tangent to the heading
            centre = (x - sign * radius * math.sin(heading), z + sign * radius * math.cos(heading))
            theta0 = math.atan2(z - centre[1], x - centre[0])
            nxt = Arc(centre[0], centre[1], radius, theta0, -sign * math.radians(draw(st.floats(20.0, 80.0))))
        segments.append(nxt)
        x, z = nxt.end
        heading = math.atan2(*reversed(nxt.direction_at(1.0)))
    return Profile(tuple(segments))


@settings(max_examples=150, deadline=None)
@given(chains(), st.integers(0, 60), st.floats(0.0, 1.0))
def test_features_cover_the_profile_and_touches_stay_on_them(profile, count, inset):
    found = features(profile)
    assert found[0].first == 0 and found[-1].stop == len(profile.segments)
    for before, after in zip(found, found[1:]):
        assert before.stop == after.first and before.s1 == after.s0
        assert before.turn_out == after.turn_in
    for feature in found:  # one kind of segment, and each segment but the first continues the one before
        kinds = {type(profile.segments[i]) for i in range(feature.first, feature.stop)}
        assert len(kinds) == 1
    assert len(owners(found)) == len(profile.segments)
    try:
        placed = spread(found, count, inset, radius=3.0, clearance=1.0)
    except SpreadError as exc:
        assert exc.wanted is None or count < exc.wanted
        return
    assert sum(placed.counts) == count
    for feature, touches, (start, end) in zip(found, placed.counts, placed.insets):
        assert touches == 0 or touches >= MIN_TOUCHES
        on = placed.s[(placed.s >= feature.s0 + start - 1e-9) & (placed.s <= feature.s1 - end + 1e-9)]
        assert len(on) >= touches
