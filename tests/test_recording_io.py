"""Reading recordings (issue 3): CSV, thesis xlsx, TDMS; every bad input named by file, column, row."""

import numpy as np
import pytest

from plant.errors import DataError
from plant.recording import Block, Recording, write_recording_csv
from plant.recording_io import parse_column_map, read_recording

FS = 1000.0


def block(f_hz, seconds=3.0, amp_i=0.5, gain=0.04, phase=-0.3):
    t = np.arange(int(seconds * FS)) / FS
    i = amp_i * np.sin(2 * np.pi * f_hz * t)
    v = gain * amp_i * np.sin(2 * np.pi * f_hz * t + phase)
    return t, i, v


def write_csv(path, rows, header="frequency_hz,time_s,current_a,velocity_m_per_s"):
    path.write_text(header + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return path


def good_rows(freqs=(2.0, 5.0)):
    rows = []
    for f in freqs:
        t, i, v = block(f)
        rows += [(f, a, b, c) for a, b, c in zip(t, i, v)]
    return rows


def test_csv_round_trip(tmp_path):
    blocks = []
    for f in (2.0, 5.0):
        t, i, v = block(f)
        blocks.append(Block(f, t, i, np.vstack([v, 2 * v])))
    rec = Recording(tuple(blocks), ("velocity_y1_m_per_s", "velocity_y2_m_per_s"))
    write_recording_csv(rec, tmp_path / "r.csv")
    back = read_recording(tmp_path / "r.csv")
    assert back.output_names == rec.output_names
    assert np.allclose(back.blocks[1].velocity_m_per_s, rec.blocks[1].velocity_m_per_s, rtol=1e-8)
    assert np.allclose(back.f_hz, [2.0, 5.0])


def test_thesis_xlsx_layout_with_column_map(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    for f in (2.0, 5.0):           # thesis Appendix B: frequency col 2, current col 3, velocities 6 and 7
        _, i, v = block(f)
        for a, b in zip(i, v):
            ws.append([0, f, a, 0, 0, b * 1e3, 2 * b * 1e3])        # velocities in mm/s
    wb.save(tmp_path / "stage_y.xlsx")
    cols = parse_column_map("frequency=2,current=3,velocity=6,velocity=7")
    rec = read_recording(tmp_path / "stage_y.xlsx", columns=cols, scale={"velocity": 1e-3}, sample_rate_hz=FS)
    assert len(rec.output_names) == 2 and rec.f_hz.tolist() == [2.0, 5.0]
    _, _, v = block(5.0)
    assert np.allclose(rec.blocks[1].velocity_m_per_s[1], 2 * v)
    with pytest.raises(DataError, match="no time column; give the sample rate"):
        read_recording(tmp_path / "stage_y.xlsx", columns=cols)
    with pytest.raises(DataError, match="need a column map"):
        read_recording(tmp_path / "stage_y.xlsx")


def test_tdms_by_channel_name(tmp_path):
    nptdms = pytest.importorskip("nptdms")
    f, t, i, v = [], [], [], []
    for fb in (2.0, 5.0):
        tb, ib, vb = block(fb)
        f += [fb] * tb.size
        t += list(tb)
        i += list(ib)
        v += list(vb)
    with nptdms.TdmsWriter(tmp_path / "x.tdms") as w:
        w.write_segment([nptdms.ChannelObject("g", name, np.asarray(data, float))
                         for name, data in (("Freq", f), ("Time", t), ("I", i), ("V1", v))])
    rec = read_recording(tmp_path / "x.tdms", columns=parse_column_map("frequency=Freq,time=Time,current=I,velocity=V1"))
    assert rec.f_hz.tolist() == [2.0, 5.0] and np.allclose(rec.blocks[0].current_a, block(2.0)[1])
    with pytest.raises(DataError, match="no channel 'V9'"):
        read_recording(tmp_path / "x.tdms", columns=parse_column_map("frequency=Freq,current=I,velocity=V9"))


def _mutate(tmp_path, edit):
    rows = [list(r) for r in good_rows()]
    edit(rows)
    return write_csv(tmp_path / "bad.csv", rows)


@pytest.mark.parametrize("edit, words", [
    (lambda r: r[10].__setitem__(2, "abc"), r"row 12, column 'current_a': 'abc' is not a number"),
    (lambda r: r[20].__setitem__(3, "nan"), r"row 22, column 'velocity_m_per_s': NaN or infinite"),
    (lambda r: r[7].__setitem__(1, r[5][1]), r"block 2 Hz.*row 9, column 'time_s': time must increase"),
    (lambda r: r.extend([[2.0, k / FS, 0.1, 0.0] for k in range(10)]), r"duplicate block: 2 Hz"),
    (lambda r: [x.__setitem__(2, 0.0) for x in r if x[0] == 5.0], r"block 5 Hz.*current is zero"),
    (lambda r: [x.__setitem__(2, 0.3) for x in r if x[0] == 5.0], r"block 5 Hz.*current is constant"),
])
def test_bad_cells_and_blocks_are_located(tmp_path, edit, words):
    with pytest.raises(DataError, match=words):
        read_recording(_mutate(tmp_path, edit))


def test_missing_column_too_short_and_too_slow(tmp_path):
    path = write_csv(tmp_path / "a.csv", [(2.0, 0.0, 0.1)], header="frequency_hz,time_s,current_a")
    with pytest.raises(DataError, match="no output column"):
        read_recording(path)
    path = write_csv(tmp_path / "b.csv", [(2.0, 0.0, 0.1, 0.0)], header="frequency_hz,current_a,velocity,x")
    with pytest.raises(DataError, match="missing column 'time_s'"):
        read_recording(path)
    t, i, v = block(2.0, seconds=1.2)          # 2.4 periods: not two whole periods after settling
    with pytest.raises(DataError, match=r"block 2 Hz.*2.40 periods recorded"):
        read_recording(write_csv(tmp_path / "c.csv", [(2.0, a, b, c) for a, b, c in zip(t, i, v)]))
    t, i, v = block(300.0)                      # 1000 Hz sampling of 300 Hz: 3.3 samples per period
    with pytest.raises(DataError, match=r"3.33 samples per period; at least 4"):
        read_recording(write_csv(tmp_path / "d.csv", [(300.0, a, b, c) for a, b, c in zip(t, i, v)]))


def test_file_level_errors(tmp_path):
    with pytest.raises(DataError, match="no such file"):
        read_recording(tmp_path / "none.csv")
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(DataError, match="the file is empty"):
        read_recording(tmp_path / "e.csv")
    (tmp_path / "h.csv").write_text("frequency_hz,time_s,current_a,velocity_m_per_s\n")
    with pytest.raises(DataError, match="no data rows"):
        read_recording(tmp_path / "h.csv")
    (tmp_path / "x.dat").write_text("1")
    with pytest.raises(DataError, match="unknown file type '.dat'"):
        read_recording(tmp_path / "x.dat")
    with pytest.raises(DataError, match="unknown role 'speed'"):
        parse_column_map("frequency=2,current=3,speed=6")
    with pytest.raises(DataError, match="names no velocity column"):
        parse_column_map("frequency=2,current=3")
