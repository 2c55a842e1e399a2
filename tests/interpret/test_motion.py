"""The motion IR: the one way the interpreter makes a move."""

from __future__ import annotations

from hypothesis import given, strategies as st

from postproc.interpret.motion import ARC, LINE, REPLAY, RUN, Modal, Move, move_under

_COORD = st.one_of(st.none(), st.floats(-500, 500))


@given(kind=st.sampled_from([LINE, ARC]), ends=st.tuples(_COORD, _COORD, _COORD, _COORD), role=st.sampled_from([RUN, REPLAY]),
       exact=st.booleans(), feed=st.one_of(st.none(), st.floats(0.01, 500)), per_rev=st.booleans(),
       comp=st.sampled_from([40, 41, 42]), tool=st.one_of(st.none(), st.integers(1, 12)),
       offset=st.one_of(st.none(), st.integers(1, 99)))
def test_a_move_under_a_modal_state_takes_that_state(kind, ends, role, exact, feed, per_rev, comp, tool, offset):
    """move_under builds the Move the named-tuple constructor builds from the same fields,
    its feed, feed mode, cutter compensation, tool and offset the modal state's."""
    modal = Modal(motion=10, feed=feed, per_rev=per_rev, comp=comp, tool=tool, offset=offset)
    x0, z0, x1, z1 = ends
    made = move_under(modal, kind, 7, x0, z0, x1, z1, 1.0, 2.0, True, role, exact)
    expected = Move(kind, 7, x0, z0, x1, z1, xc=1.0, zc=2.0, cw=True, role=role, feed=feed, per_rev=per_rev, comp=comp,
                    tool=tool, exact=exact, offset=offset)
    assert type(made) is Move and made == expected and made._asdict() == expected._asdict()
    assert move_under(modal, LINE, 7, x0, z0, x1, z1) == Move(LINE, 7, x0, z0, x1, z1, feed=feed, per_rev=per_rev,
                                                              comp=comp, tool=tool, offset=offset)
