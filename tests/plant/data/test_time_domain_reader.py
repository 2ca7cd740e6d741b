"""The time-domain CSV reader: a plain numeric file is parsed straight from disk (``streamed_numbers``) and
gives what the careful line-by-line reader gives; any other file goes to the careful reader, whose errors
name the row in the file (blank lines counted)."""

import numpy as np
import pytest

from plant.data import table
from plant.data.read_time_domain import read_time_recording
from plant.data.table import streamed_numbers
from plant.errors import DataError

HEADER = "time_s,current_a,position_m,note_id"


def _rows(n=300):
    t = np.arange(n) / 1000.0
    return np.column_stack([t, 0.5 * np.sin(2 * np.pi * 3 * t), 0.01 * np.sin(2 * np.pi * 3 * t - 1), np.arange(n)])


def _write(path, rows, *, newline="\n", blank_after=None):
    lines = [HEADER] + [",".join(f"{v:.10g}" for v in r) for r in rows]
    if blank_after is not None:
        lines.insert(blank_after + 1, "")
    path.write_bytes((newline.join(lines) + newline).encode())
    return path


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_streamed_and_careful_readers_agree(tmp_path, monkeypatch, newline):
    path = _write(tmp_path / "rec.csv", _rows(), newline=newline)
    assert streamed_numbers(path) is not None
    streamed = read_time_recording(path)
    monkeypatch.setattr(table, "streamed_numbers", lambda p: None)
    careful = read_time_recording(path)
    np.testing.assert_array_equal(streamed.time_s, careful.time_s)
    np.testing.assert_array_equal(streamed.current_a, careful.current_a)
    np.testing.assert_array_equal(streamed.output, careful.output)
    np.testing.assert_array_equal(streamed.extra["note_id"], careful.extra["note_id"])
    np.testing.assert_allclose(streamed.output[0], _rows()[:, 2], rtol=1e-9)


@pytest.mark.parametrize("text", [
    HEADER + "\n0,1,2,3\n\n0.001,1,2,3\n",          # a blank line: rows shift
    HEADER + "\n0,1,x,3\n",                          # a cell that is not a number
    HEADER + "\n0,1,2\n",                            # a short row
    "\ufeff" + HEADER + "\n0,1,2,3\n",              # a byte-order mark
    HEADER + "\n",                                   # no data
    "time_s,time_s,current_a,position_m\n0,0,1,2\n",   # a repeated name
])
def test_files_that_are_not_plain_go_to_the_careful_reader(tmp_path, text):
    path = tmp_path / "rec.csv"
    path.write_bytes(text.encode("utf-8"))
    assert streamed_numbers(path) is None


def test_a_row_after_a_blank_line_is_named_by_its_line_in_the_file(tmp_path):
    rows = _rows()
    rows[200, 2] = np.nan
    path = _write(tmp_path / "rec.csv", rows, blank_after=100)
    with pytest.raises(DataError, match=r"row 203, column 'position_m': NaN"):
        read_time_recording(path)
    rows = _rows()
    rows[200, 2] = np.nan
    with pytest.raises(DataError, match=r"row 202, column 'position_m': NaN"):
        read_time_recording(_write(tmp_path / "plain.csv", rows))
