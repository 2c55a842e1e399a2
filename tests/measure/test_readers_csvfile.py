"""postproc.measure.readers.csvfile: the common shape of measurement files, read as arrays.

The data of a file come back as arrays (Table.lines, Table.values): numpy's C reader where it
reads a cell exactly as float() does, the line-by-line reading otherwise, which names the
first bad line. The two must agree on every table either can read, and a long file must not
hold a Python object per row.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.diagnostics import MeasurementError
from postproc.measure.readers import csvfile
from postproc.measure.readers.csvfile import read_table
from support.long_traces import peak_bytes, write_trace

MAGIC = "# postproc ballbar 1"
KEYS = {"radius_mm", "direction", "feed_mm_min", "start_angle_deg"}
COLUMNS = [["angle_deg", "deviation_mm"], ["deviation_mm"]]


def reference(text: str) -> tuple[list[int], list[list[float]]]:
    """The rows as the format defines them: every non-blank line after the header row, split at commas."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() and not line.strip().startswith("#"))
    rows, values = [], []
    for number, line in enumerate(lines[start + 1:], start + 2):
        if line.strip():
            rows.append(number)
            values.append([float(cell) for cell in line.strip().split(",")])
    return rows, values


number_text = st.floats(-1.0, 1.0, allow_nan=False).map(lambda v: f"{v:.7g}") | st.sampled_from(
    ["0", "-0.0", "+1.5e-3", ".5", "5.", "1E-4", " 0.25 ", "\t0.125"])


@settings(max_examples=60, deadline=None)
@given(rows=st.lists(st.tuples(number_text, number_text), min_size=1, max_size=30),
       blank=st.sampled_from(["", "\n", "  \n", "\r\n"]), where=st.integers(0, 30),
       end=st.sampled_from(["\n", "\r\n"]), trailing=st.sampled_from(["", "\n\n", "  \n"]))
def test_read_table_fast_and_line_by_line_agree(tmp_path_factory, rows, blank, where, end, trailing):
    lines = [f"{a},{b}" for a, b in rows]
    lines.insert(min(where, len(lines)), blank.rstrip("\r\n")) if blank else None
    text = end.join([MAGIC, "# radius_mm = 100", "# direction = cw", "angle_deg,deviation_mm", *lines]) + end + trailing
    path = tmp_path_factory.mktemp("t") / "trace.csv"
    path.write_bytes(text.encode())
    table = read_table(str(path), MAGIC, KEYS, COLUMNS)
    expected_rows, expected_values = reference(text)
    assert table.lines.tolist() == expected_rows
    assert table.values.tolist() == expected_values


def test_plain_data_is_read_in_c_and_anything_else_line_by_line():
    assert csvfile._fast_values("1,2\r\n3,4\n", 2).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    for data in ("1,2\n\n3,4\n", "\n1,2\n", "1,2\n# c\n", "nan,1\n", "1,2\r3,4\n", "1_0,2\n", "1,2,3\n", "1e999,1\n"):
        assert csvfile._fast_values(data, 2) is None, data


@pytest.mark.parametrize("cell, said", [("nan", "is not a finite number"), ("1;2", "is not a finite number"),
                                        ("", "is not a finite number")])
def test_a_bad_cell_deep_in_a_long_file_is_named_at_its_line(tmp_path, cell, said):
    path = write_trace(tmp_path / "long.csv", 50_000, "cw")
    lines = path.read_text().splitlines()
    lines[30_000] = f"12.5,{cell}"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MeasurementError) as caught:
        read_table(str(path), MAGIC, KEYS, COLUMNS)
    assert caught.value.location.line == 30_001
    assert said in caught.value.message


def test_a_long_file_holds_no_python_object_per_row(tmp_path):
    """200k rows: the text, its bytes and the arrays; a tuple and a list per row (as the reader
    once kept) cost some 200 bytes a row more."""
    count = 200_000
    path = write_trace(tmp_path / "long.csv", count, "ccw")
    peak, table = peak_bytes(read_table, str(path), MAGIC, KEYS, COLUMNS)
    assert table.values.shape == (count, 2) and table.lines[0] == 6 and table.lines[-1] == count + 5
    assert peak < 150 * count, f"{peak / count:.0f} bytes per row"
