"""Reading recordings, the cases real files bring: blank lines and formatted empty rows,
TDMS groups and waveform timing, per-column unit scales (the thesis scales its second velocity
column by 100, Appendix B-I), a column named twice, and the shortest block the estimator takes.

Reference values are the synthetic signals written here (closed form).
"""

import re
import warnings

import numpy as np
import pytest

from plant.data.read import parse_column_map, parse_scale
from plant.data.read_stepped_sine import read_recording
from plant.errors import DataError
from plant.estimate.lockin import estimate_response

FS = 1000.0
GAIN, PHASE = 0.04, -0.3          # synthetic plant: v = GAIN * i shifted by PHASE (closed form)
HEADER = "frequency_hz,time_s,current_a,velocity_m_per_s"


def signals(f_hz, seconds=3.0, amp_i=0.5):
    t = np.arange(int(round(seconds * FS))) / FS
    return t, amp_i * np.sin(2 * np.pi * f_hz * t), GAIN * amp_i * np.sin(2 * np.pi * f_hz * t + PHASE)


def csv_lines(freqs=(2.0, 5.0), seconds=3.0):
    lines = []
    for f in freqs:
        t, i, v = signals(f, seconds)
        lines += [f"{f},{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), i.tolist(), v.tolist())]
    return lines


def where(path):
    return re.escape(str(path)) + ": "


def test_blank_csv_lines_are_skipped_and_rows_keep_their_file_numbers(tmp_path):
    lines = csv_lines()
    lines.insert(10, "")                       # file row 12 is blank (header = row 1)
    lines.insert(3000, "   ")                  # and a whitespace-only line between the blocks
    path = tmp_path / "blank.csv"
    path.write_text(HEADER + "\n" + "\n".join(lines) + "\n\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = read_recording(path)
    assert [b.time_s.size for b in rec.blocks] == [3000, 3000]
    assert np.allclose(rec.blocks[0].current_a, signals(2.0)[1])
    # a bad cell after the blank line is named by its row in the file, in the fast and slow paths
    lines[40] = lines[40].rsplit(",", 1)[0] + ",nan"          # file row 42
    path.write_text(HEADER + "\n" + "\n".join(lines) + "\n")
    with pytest.raises(DataError, match=where(path) + r"row 42, column 'velocity_m_per_s': NaN or infinite"):
        read_recording(path)
    lines[40] = lines[40].rsplit(",", 1)[0] + ",x"
    path.write_text(HEADER + "\n" + "\n".join(lines) + "\n")
    with pytest.raises(DataError, match=where(path) + r"row 42, column 'velocity_m_per_s': 'x' is not a number"):
        read_recording(path)


def test_xlsx_formatting_below_the_data_and_per_column_scales(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    for f in (2.0, 5.0):            # thesis Appendix B-I layout: frequency col 2, current col 3, velocities 6, 7
        _, i, v = signals(f, seconds=1.5)
        for a, b in zip(i, v):
            ws.append([0, f, a, None, None, b * 1e3, b * 10.0])   # mm/s, and the thesis's 1/100-scaled column
    for row in range(3003, 3010):
        ws.cell(row=row, column=2).number_format = "0.00"         # formatted, empty: read as rows of None
    path = tmp_path / "stage_y.xlsx"
    wb.save(path)
    cols = parse_column_map("frequency=2,current=3,velocity=6,velocity=7")
    rec = read_recording(path, columns=cols, scale=parse_scale("velocity=1e-3,velocity:7=100"), sample_rate_hz=FS)
    _, _, v = signals(5.0, seconds=1.5)
    assert rec.f_hz.tolist() == [2.0, 5.0] and rec.blocks[1].time_s.size == 1500
    assert np.allclose(rec.blocks[1].velocity_m_per_s, [v, v], rtol=1e-12)      # 1e3 * 1e-3, 10 * 1e-3 * 100
    with pytest.raises(DataError, match=where(path) + r"scale velocity:8: no velocity column '8' \(the velocity "
                                                      r"columns are '6', '7'\)"):
        read_recording(path, columns=cols, scale={"velocity:8": 2.0}, sample_rate_hz=FS)
    ws.cell(row=100, column=6).value = None    # an empty cell inside the data is an error, not a skipped row
    wb.save(path)
    with pytest.raises(DataError, match=where(path) + r"row 100, column 6 \(velocity\): None is not a number"):
        read_recording(path, columns=cols, sample_rate_hz=FS)


def test_tdms_groups_and_waveform_timing(tmp_path):
    nptdms = pytest.importorskip("nptdms")
    f = np.concatenate([np.full(3000, 2.0), np.full(3000, 5.0)])
    i = np.concatenate([signals(2.0)[1], signals(5.0)[1]])
    v = np.concatenate([signals(2.0)[2], signals(5.0)[2]])
    wf = {"wf_increment": 1.0 / FS, "wf_start_offset": 0.0}
    path = tmp_path / "daq.tdms"
    with nptdms.TdmsWriter(path) as w:
        w.write_segment([nptdms.ChannelObject("drive", "Freq", f), nptdms.ChannelObject("drive", "I", i, properties=wf),
                         nptdms.ChannelObject("encoder", "V", v), nptdms.ChannelObject("encoder", "I", 2 * i)])
    with pytest.raises(DataError, match=where(path) + r"channel 'I' \(current\) is in several groups; name it as "
                                                      r"'drive/I' or 'encoder/I'"):
        read_recording(path, columns=parse_column_map("frequency=Freq,current=I,velocity=V"))
    # no time channel: the waveform increment of the current channel (1 ms) gives the time
    rec = read_recording(path, columns=parse_column_map("frequency=Freq,current=drive/I,velocity=encoder/V"))
    assert np.allclose(rec.blocks[0].time_s, signals(2.0)[0], rtol=0, atol=1e-12)
    assert estimate_response(rec).response[0, 0] == pytest.approx(GAIN * np.exp(1j * PHASE), rel=1e-9)
    # an explicit sample rate wins over the file's
    rec = read_recording(path, columns=parse_column_map("frequency=Freq,current=drive/I,velocity=V"),
                         sample_rate_hz=2 * FS)
    assert rec.blocks[0].time_s[1] == pytest.approx(0.5e-3)


def test_column_named_twice_and_bad_scale_text():
    with pytest.raises(DataError, match=r"column map 'frequency=2,current=3,velocity=6,velocity=6' names column "
                                        r"'6' twice"):
        parse_column_map("frequency=2,current=3,velocity=6,velocity=6")
    assert parse_scale(" velocity=1e-3, current:3=2 ") == {"velocity": 1e-3, "current:3": 2.0}
    for text in ("velocity", "velocity=mm", "=2"):
        with pytest.raises(DataError, match=r"scale item .*: expected ROLE=FACTOR or ROLE:COLUMN=FACTOR"):
            parse_scale(text)


def test_three_whole_periods_are_enough(tmp_path):
    """3000 samples at 1 kHz hold exactly 3 periods of 1 Hz (n / fs, not (n - 1) / fs): the reader takes
    the block and the estimator keeps at least two periods of it; 2.999 periods are taken too (partial
    periods are fitted), exactly (closed form)."""
    path = tmp_path / "short.csv"
    for seconds in (3.0, 2.999):
        path.write_text(HEADER + "\n" + "\n".join(csv_lines((1.0,), seconds=seconds)) + "\n")
        m = estimate_response(read_recording(path))
        assert m.metadata["periods_used"][0] >= 2.0
        assert m.response[0, 0] == pytest.approx(GAIN * np.exp(1j * PHASE), rel=1e-9)
