"""AU CSV round trip, gap filling and bad-input messages of every CSV reader (the formats' own
round trips: test_io_livelink.py, test_io_openface.py, test_io_pyfeat.py)."""

import numpy as np
import pytest

from mimika.errors import DataError
from mimika.io.tracks import (
    detect_format,
    fill_gaps,
    read_track,
    write_track,
)
from mimika.tracks import AUTrack

PRIMARY = ("AU01", "AU02", "AU04", "AU05", "AU06", "AU07", "AU09", "AU10", "AU12", "AU12L",
           "AU15", "AU17", "AU18", "AU20", "AU22", "AU24", "AU27", "AU28", "AU45", "AU61", "AU63")


@pytest.fixture
def track(rng):
    t = np.linspace(0, 1, 31)[:, None]
    vals = 0.5 + 0.5 * np.sin(2 * np.pi * (t + rng.uniform(0, 1, len(PRIMARY))))
    return AUTrack(np.clip(vals * 0.9, 0, 1), PRIMARY, 30.0)


def test_au_csv_roundtrip(tmp_path, track):
    p = write_track(track, tmp_path / "t.csv")
    assert p.read_text().splitlines()[0] == "time," + ",".join(PRIMARY)
    back = read_track(p)
    assert detect_format(p) == "au" and back.fps == 30.0 and back.channels == track.channels
    assert np.abs(back.values - track.values).max() <= 5e-7 + 1e-7  # 6 decimals (+ float32)


def test_fill_gaps_methods():
    v = np.array([[0.0], [9.0], [9.0], [3.0], [9.0]])
    ok = np.array([True, False, False, True, False])
    assert fill_gaps(v, ok)[:, 0].tolist() == [0, 1, 2, 3, 3]
    assert fill_gaps(v, ok, method="hold")[:, 0].tolist() == [0, 0, 0, 3, 3]
    assert fill_gaps(v, ok, method="nearest")[:, 0].tolist() == [0, 0, 3, 3, 3]


@pytest.mark.parametrize("text, pattern", [
    ("time,AU01\n0,0.5\n0.04,zero\n", r"x.csv:3:AU01: 'zero' is not a number"),
    ("time,AU1x\n0,0.5\n", r"x.csv:1:AU1x: unknown Action Unit"),
    ("time,AU01\n0,0.5,1\n", r"x.csv:2: 3 fields"),
    ("time,AU01\n0,1.5\n", r"x.csv:2:AU01: 1.5 is outside"),
    ("time,AU01\n0.1,0.5\n0.0,0.5\n", r"x.csv:3: time 0 does not increase"),
    ("Timecode,BlendShapeCount,EyeBlinkLeft\n", r"x.csv:1: missing column\(s\) EyeLookDownLeft"),
    ("frame, face_id, timestamp, success\n1, 0, 0, 1\n", r"x.csv:1: no AU intensity"),
    ("hello,world\n", r"x.csv:1: unknown CSV layout"),
    ("", r"x.csv:1: unknown CSV layout"),
])
def test_bad_csv_messages(tmp_path, text, pattern):
    p = tmp_path / "x.csv"
    p.write_text(text)
    with pytest.raises(DataError, match=pattern):
        read_track(p)


def test_livelink_non_number_names_row_and_column(tmp_path, track):
    p = write_track(track, tmp_path / "ll.csv", format="arkit")
    lines = p.read_text().splitlines()
    cells = lines[3].split(",")
    cells[5] = "oops"
    lines[3] = ",".join(cells)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"ll.csv:4:EyeLookOutLeft: 'oops' is not a number"):
        read_track(p)
