"""Reading recordings: CSV, the thesis's xlsx layout, TDMS; every bad input is named
by file and by column, row or block.

Reference values are the synthetic signals written here (closed form): what is read back must be
what was written, times the stated unit scale factor.
"""

import os
import re
import stat
import warnings

import numpy as np
import pytest

from plant.data.read import parse_column_map
from plant.data.read_stepped_sine import read_recording
from plant.data.recordings import Block, Recording
from plant.data.writers import write_recording_csv
from plant.errors import DataError
from plant.estimate.lockin import estimate_response
from plant.host.files import atomic_write_text, atomic_write_texts

FS = 1000.0
GAIN, PHASE = 0.04, -0.3        # synthetic plant: v = GAIN * i shifted by PHASE (closed form)
HEADER = "frequency_hz,time_s,current_a,velocity_m_per_s"


def signals(f_hz, seconds=3.0, amp_i=0.5):
    t = np.arange(int(round(seconds * FS))) / FS
    i = amp_i * np.sin(2 * np.pi * f_hz * t)
    v = GAIN * amp_i * np.sin(2 * np.pi * f_hz * t + PHASE)
    return t, i, v


def rows_of(freqs=(2.0, 5.0), seconds=3.0):
    rows = []
    for f in freqs:
        t, i, v = signals(f, seconds)
        rows += [[f, a, b, c] for a, b, c in zip(t, i, v)]
    return rows


def write_csv(path, rows, header=HEADER):
    path.write_text(header + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return path


def where(path):
    """Regex for the file name at the start of a message."""
    return re.escape(str(path)) + ": "


# --- good files ------------------------------------------------------------------------------

def test_csv_round_trip_two_outputs_unsorted_blocks(tmp_path):
    blocks = []
    for f in (7.25, 2.5):                         # written out of order, read back sorted
        t, i, v = signals(f)
        blocks.append(Block(f, t, i, np.vstack([v, -3 * v])))
    rec = Recording(tuple(blocks), ("velocity_y1_m_per_s", "velocity_y2_m_per_s"))
    path = tmp_path / "r.csv"
    write_recording_csv(rec, path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv"]     # no temporary file left
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = read_recording(path)
    assert back.source == str(path)
    assert back.output_names == rec.output_names
    assert back.f_hz.tolist() == [2.5, 7.25]
    for got, sent in zip(back.blocks, rec.blocks[::-1]):
        # written with 9 significant digits (plant.data.recordings.write_recording_csv)
        assert np.allclose(got.time_s, sent.time_s, rtol=0, atol=1e-9)
        assert np.allclose(got.current_a, sent.current_a, rtol=1e-8, atol=1e-15)
        assert np.allclose(got.velocity_m_per_s, sent.velocity_m_per_s, rtol=1e-8, atol=1e-15)
        assert got.sample_rate_hz == pytest.approx(FS)


def test_good_file_loads_and_estimates_warning_free(tmp_path):
    path = write_csv(tmp_path / "good.csv", rows_of())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = estimate_response(read_recording(path))
    # closed form: v / i = GAIN e^{j PHASE}
    assert np.allclose(m.response[0], GAIN * np.exp(1j * PHASE), rtol=1e-6)


def test_utf8_byte_order_mark_is_ignored(tmp_path):
    path = tmp_path / "bom.csv"
    write_csv(path, rows_of())
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())      # "CSV UTF-8" export of spreadsheet programs
    assert read_recording(path).f_hz.tolist() == [2.0, 5.0]


def test_thesis_xlsx_layout_with_column_map_and_unit_scales(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    for f in (4.0, 10.0):  # thesis Appendix B: no header, frequency col 2, current col 3, velocities cols 6, 7
        _, i, v = signals(f, seconds=1.0)
        for a, b in zip(i, v):
            ws.append([0, f, 1e3 * a, 0, 0, 1e3 * b, -2e3 * b])   # current in mA, velocities in mm/s
    path = tmp_path / "stage_y.xlsx"
    wb.save(path)
    cols = parse_column_map("frequency=2,current=3,velocity=6,velocity=7")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = read_recording(path, columns=cols, scale={"velocity": 1e-3, "current": 1e-3}, sample_rate_hz=FS)
    assert rec.output_names == ("velocity_1_m_per_s", "velocity_2_m_per_s")
    assert rec.f_hz.tolist() == [4.0, 10.0]
    t, i, v = signals(10.0, seconds=1.0)
    assert np.allclose(rec.blocks[1].time_s, t)                      # from sample_rate_hz
    assert np.allclose(rec.blocks[1].current_a, i, rtol=1e-12)        # mA -> A
    assert np.allclose(rec.blocks[1].velocity_m_per_s, [v, -2 * v], rtol=1e-12)   # mm/s -> m/s
    m = estimate_response(rec)
    assert np.allclose(m.response[1], -2 * GAIN * np.exp(1j * PHASE), rtol=1e-6)   # closed form


def test_tdms_by_channel_names_with_scale(tmp_path):
    nptdms = pytest.importorskip("nptdms")
    data = {"Freq": [], "Time": [], "I": [], "V1": [], "V2": []}
    for f in (2.0, 5.0):
        t, i, v = signals(f)
        data["Freq"] += [f] * t.size
        data["Time"] += list(1e3 * t)                 # milliseconds
        data["I"] += list(i)
        data["V1"] += list(1e3 * v)                   # mm/s
        data["V2"] += list(2e3 * v)
    path = tmp_path / "run.tdms"
    with nptdms.TdmsWriter(path) as w:
        w.write_segment([nptdms.ChannelObject("scope", name, np.asarray(x, float)) for name, x in data.items()])
    cols = parse_column_map("frequency=Freq,time=Time,current=I,velocity=V1,velocity=V2")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = read_recording(path, columns=cols, scale={"time": 1e-3, "velocity": 1e-3})
    assert rec.output_names == ("velocity_V1", "velocity_V2")
    t, i, v = signals(2.0)
    assert np.allclose(rec.blocks[0].time_s, t, rtol=0, atol=1e-12)
    assert np.allclose(rec.blocks[0].current_a, i)
    assert np.allclose(rec.blocks[0].velocity_m_per_s, [v, 2 * v], rtol=1e-12)
    channels = r"no channel 'V9' \(velocity\); channels: (scope/)?Freq, (scope/)?Time"
    with pytest.raises(DataError, match=where(path) + channels):
        read_recording(path, columns=parse_column_map("frequency=Freq,current=I,velocity=V9"))


def test_csv_with_column_map_of_header_names_and_scale(tmp_path):
    rows = [[f, t, i, 1e3 * v] for f, t, i, v in rows_of()]
    path = write_csv(tmp_path / "m.csv", rows, header="f,t,i,v_mm_s")
    rec = read_recording(path, columns=parse_column_map("frequency=f,time=t,current=i,velocity=v_mm_s"),
                         scale={"velocity": 1e-3})
    assert np.allclose(rec.blocks[0].velocity_m_per_s[0], signals(2.0)[2], rtol=1e-12)
    with pytest.raises(DataError, match=where(path) + "no time column; give the sample rate"):
        read_recording(path, columns=parse_column_map("frequency=f,current=i,velocity=v_mm_s"))


# --- bad input: every message names the file and the column, row or block ---------------------

def _bad_csv(tmp_path, edit):
    rows = rows_of()               # rows 2..3001: 2 Hz block, rows 3002..6001: 5 Hz block
    edit(rows)
    return write_csv(tmp_path / "bad.csv", rows)


def _set_current(rows, value, f_hz=5.0):
    for r in rows:
        if r[0] == f_hz:
            r[2] = value


@pytest.mark.parametrize("edit, message", [
    (lambda r: r[10].__setitem__(2, "abc"), r"row 12, column 'current_a': 'abc' is not a number"),
    (lambda r: r[10].__setitem__(3, ""), r"row 12, column 'velocity_m_per_s': '' is not a number"),
    (lambda r: r[3005].__setitem__(0, "5 Hz"), r"row 3007, column 'frequency_hz': '5 Hz' is not a number"),
    (lambda r: r[20].__setitem__(3, "nan"), r"row 22, column 'velocity_m_per_s': NaN or infinite sample"),
    (lambda r: r[4000].__setitem__(2, "inf"), r"row 4002, column 'current_a': NaN or infinite sample"),
    (lambda r: r[30].__setitem__(1, "-inf"), r"row 32, column 'time_s': NaN or infinite sample"),
    (lambda r: r[7].__setitem__(1, r[6][1]),
     r"block 2 Hz \(rows 2-3001\): row 9, column 'time_s': time must increase within a block"),
    (lambda r: r[3100].__setitem__(1, 0.05),
     r"block 5 Hz \(rows 3002-6001\): row 3102, column 'time_s': time must increase within a block"),
    (lambda r: r.extend(rows_of((2.0,))), r"duplicate block: 2 Hz appears at rows 2 and 6002"),
    (lambda r: r[100].__setitem__(0, -2.0), r"row 102, column 'frequency_hz': frequency must be positive"),
])
def test_bad_cells_and_blocks_are_located(tmp_path, edit, message):
    path = _bad_csv(tmp_path, edit)
    with pytest.raises(DataError, match=where(path) + message):
        read_recording(path)


def test_missing_columns_are_named(tmp_path):
    path = write_csv(tmp_path / "a.csv", [(2.0, 0.0, 0.1)], header="frequency_hz,time_s,current_a")
    with pytest.raises(DataError, match=where(path) + "no output column: expected one or more columns whose "
                                                      "names start with 'velocity'"):
        read_recording(path)
    path = write_csv(tmp_path / "b.csv", [(2.0, 0.1, 0.0)], header="frequency_hz,time_s,velocity_m_per_s")
    with pytest.raises(DataError, match=where(path) + r"missing column 'current_a' \(header: frequency_hz, "):
        read_recording(path)
    path = write_csv(tmp_path / "c.csv", [(2.0, 0.0, 0.1, 0.0)])
    with pytest.raises(DataError, match=where(path) + "missing column 'speed'"):
        read_recording(path, columns=parse_column_map("frequency=frequency_hz,current=current_a,velocity=speed"))
    # a short row: the cell of the missing column
    path = write_csv(tmp_path / "d.csv", [r if k != 40 else r[:3] for k, r in enumerate(rows_of())])
    with pytest.raises(DataError, match=where(path) + r"row 42, column 'velocity_m_per_s': '<missing>'"):
        read_recording(path)


def test_a_bad_block_is_left_out_by_the_estimator_not_refused_by_the_reader(tmp_path):
    """Block length, sampling and current are the estimator's questions: it leaves such a block out
    with a note and estimates the others; only when none is left does it refuse, naming the file."""
    rows = rows_of((2.0,), seconds=0.4) + rows_of((5.0,))   # 2 Hz for 0.4 s: 0.80 periods
    path = write_csv(tmp_path / "short.csv", rows)
    m = estimate_response(read_recording(path))
    assert m.f_hz.tolist() == [5.0] and m.metadata["excluded_f_hz"] == [2.0]
    assert any(re.match(r"block 2 Hz: 0\.80 periods left after settling .*at least 1 period is needed", n)
               for n in m.notes)
    for current, what in ((0.0, "has no component at 5 Hz"), (0.3, "has no component at 5 Hz")):
        rows = rows_of()
        _set_current(rows, current)
        m = estimate_response(read_recording(write_csv(tmp_path / "flat.csv", rows)))
        assert m.f_hz.tolist() == [2.0]
        assert any(f"block 5 Hz: the current {what}" in n for n in m.notes)
        assert estimate_response(read_recording(tmp_path / "flat.csv"), method="rms").f_hz.tolist() == [2.0]
    path = write_csv(tmp_path / "slow.csv", rows_of((300.0,)))   # 1000 Hz sampling of 300 Hz
    with pytest.raises(DataError, match=where(path) + r"no usable block: block 300 Hz: 3\.33 samples per period; "
                                                      r"at least 4 are needed"):
        estimate_response(read_recording(path))
    # exactly 4 samples per period is accepted, and the lock-in is exact there (closed form)
    m = estimate_response(read_recording(write_csv(tmp_path / "four.csv", rows_of((250.0,)))))
    assert m.response[0, 0] == pytest.approx(GAIN * np.exp(1j * PHASE), rel=1e-6)


def test_file_level_errors(tmp_path):
    with pytest.raises(DataError, match=where(tmp_path / "none.csv") + "no such file"):
        read_recording(tmp_path / "none.csv")
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(DataError, match=where(tmp_path / "e.csv") + "the file is empty"):
        read_recording(tmp_path / "e.csv")
    (tmp_path / "h.csv").write_text(HEADER + "\n")
    with pytest.raises(DataError, match=where(tmp_path / "h.csv") + "no data rows"):
        read_recording(tmp_path / "h.csv")
    (tmp_path / "x.dat").write_text("1")
    with pytest.raises(DataError, match=where(tmp_path / "x.dat") + r"unknown file type '\.dat'; expected \.csv"):
        read_recording(tmp_path / "x.dat")
    (tmp_path / "broken.xlsx").write_text("not a zip")
    with pytest.raises(DataError, match=where(tmp_path / "broken.xlsx") + "cannot read the workbook"):
        read_recording(tmp_path / "broken.xlsx", columns=parse_column_map("frequency=2,current=3,velocity=6"))
    with pytest.raises(DataError, match=r"scale speed=2\.0: role must be one of"):
        read_recording(write_csv(tmp_path / "g.csv", rows_of()), scale={"speed": 2.0})
    with pytest.raises(DataError, match=r"scale velocity='x'"):
        read_recording(tmp_path / "g.csv", scale={"velocity": "x"})
    with pytest.raises(DataError, match=r"scale velocity=0"):
        read_recording(tmp_path / "g.csv", scale={"velocity": 0})


def test_spreadsheet_errors(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    _, i, v = signals(4.0, seconds=1.0)
    for k, (a, b) in enumerate(zip(i, v)):
        ws.append([0, 4.0, "n/a" if k == 99 else a, 0, 0, b])
    path = tmp_path / "t.xlsx"
    wb.save(path)
    cols = parse_column_map("frequency=2,current=3,velocity=6")
    with pytest.raises(DataError, match=where(path) + "spreadsheets and TDMS files need a column map"):
        read_recording(path)
    with pytest.raises(DataError, match=where(path) + r"row 100, column 3 \(current\): 'n/a' is not a number"):
        read_recording(path, columns=cols, sample_rate_hz=FS)
    with pytest.raises(DataError, match=where(path) + r"row 1, column 9 \(velocity\): None is not a number"):
        read_recording(path, columns=parse_column_map("frequency=2,current=4,velocity=9"), sample_rate_hz=FS)
    with pytest.raises(DataError, match=where(path) + r"spreadsheet column velocity='F' must be a 1-based column"):
        read_recording(path, columns=parse_column_map("frequency=2,current=3,velocity=F"), sample_rate_hz=FS)
    ws.cell(row=100, column=3, value=0.1)
    ws.cell(row=50, column=6, value="nan")
    wb.save(path)
    with pytest.raises(DataError, match=where(path) + r"row 50, column 6 \(velocity\): NaN or infinite sample"):
        read_recording(path, columns=cols, sample_rate_hz=FS)
    with pytest.raises(DataError, match=where(path) + "no time column; give the sample rate"):
        read_recording(path, columns=cols)
    wb = openpyxl.Workbook()
    wb.save(tmp_path / "empty.xlsx")
    with pytest.raises(DataError, match=where(tmp_path / "empty.xlsx") + "the sheet is empty"):
        read_recording(tmp_path / "empty.xlsx", columns=cols, sample_rate_hz=FS)


def test_tdms_errors(tmp_path):
    nptdms = pytest.importorskip("nptdms")
    path = tmp_path / "empty.tdms"
    with nptdms.TdmsWriter(path) as w:
        w.write_segment([nptdms.ChannelObject("g", name, np.zeros(0)) for name in ("F", "I", "V")])
    cols = parse_column_map("frequency=F,current=I,velocity=V")
    with pytest.raises(DataError, match=where(path) + "no data rows"):
        read_recording(path, columns=cols, sample_rate_hz=FS)
    with pytest.raises(DataError, match=where(path) + "spreadsheets and TDMS files need a column map"):
        read_recording(path)
    path = tmp_path / "ragged.tdms"
    with nptdms.TdmsWriter(path) as w:
        w.write_segment([nptdms.ChannelObject("g", name, np.ones(n)) for name, n in (("F", 10), ("I", 10), ("V", 9))])
    with pytest.raises(DataError, match=where(path) + "channel 'V' has 9 samples, others 10"):
        read_recording(path, columns=cols, sample_rate_hz=FS)
    f, i, v = (np.asarray(x) for x in zip(*[(r[0], r[2], r[3]) for r in rows_of()]))
    i[4500] = np.inf
    path = tmp_path / "inf.tdms"
    with nptdms.TdmsWriter(path) as w:
        w.write_segment([nptdms.ChannelObject("g", n, x) for n, x in (("F", f), ("I", i), ("V", v))])
    with pytest.raises(DataError, match=where(path) + r"row 4501, channel 'I' \(current\): NaN or infinite"):
        read_recording(path, columns=cols, sample_rate_hz=FS)


@pytest.mark.parametrize("text, message", [
    ("frequency=2,current=3,speed=6", r"column map item 'speed=6': unknown role 'speed'; roles are frequency, time"),
    ("frequency=2,current3,velocity=6", r"column map item 'current3': expected ROLE=COLUMN"),
    ("frequency=2,current=,velocity=6", r"column map item 'current=': expected ROLE=COLUMN"),
    ("frequency=2,current=3", r"column map 'frequency=2,current=3' names no output: give velocity=\.\.\. or position"),
    ("time=t,current=3,velocity=v,position=q", r"names both velocity and position outputs"),
    ("frequency=2,frequency=4,current=3,velocity=6", r"names 2 frequency columns; give one"),
    ("", r"column map '' names no current column"),
])
def test_bad_column_map_text(text, message):
    with pytest.raises(DataError, match=message):
        parse_column_map(text)


def test_column_map_parsing():
    assert parse_column_map(" frequency=2, current=3 ,velocity=6,velocity=7,time=1") == {
        "frequency": ["2"], "current": ["3"], "velocity": ["6", "7"], "time": ["1"]}


def test_atomic_write_keeps_the_old_file_on_failure(tmp_path):
    path = tmp_path / "out.csv"
    atomic_write_text(path, "old\n")
    with pytest.raises(UnicodeEncodeError):
        atomic_write_text(path, "new \ud800\n")          # a lone surrogate cannot be encoded mid-write
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_atomic_write_goes_through_a_link_and_keeps_permissions(tmp_path):
    target, link, new = tmp_path / "real.csv", tmp_path / "link.csv", tmp_path / "new.csv"
    target.write_text("old\n")
    target.chmod(0o640)
    link.symlink_to(target.name)
    atomic_write_texts({link: "new\n", new: "fresh\n"})
    assert link.is_symlink() and os.readlink(link) == "real.csv"
    assert target.read_text() == "new\n" and stat.S_IMODE(target.stat().st_mode) == 0o640
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(new.stat().st_mode) == 0o666 & ~umask
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "new.csv", "real.csv"]


def test_atomic_write_through_a_dangling_link_creates_its_target(tmp_path):
    (tmp_path / "sub").mkdir()
    link = tmp_path / "link.csv"
    link.symlink_to(tmp_path / "sub" / "made.csv")
    atomic_write_text(link, "x\n")
    assert link.is_symlink() and (tmp_path / "sub" / "made.csv").read_text() == "x\n"
