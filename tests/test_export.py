"""AU CSV, OpenFace and Live Link (ARKit) export → import round trips and bad-input messages."""

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


def test_openface_roundtrip(tmp_path, track):
    p = write_track(track, tmp_path / "of.csv", format="openface")
    head = p.read_text().splitlines()[0]
    assert head.startswith("frame, face_id, timestamp, confidence, success, gaze_0_x")
    assert "AU01_c" in head and "AU28_c" in head
    back = read_track(p)
    assert detect_format(p) == "openface" and back.fps == 30.0
    folded = track["AU12"] + track["AU12L"] / 2
    assert np.abs(back["AU12"] - np.clip(folded, 0, 1)).max() <= 0.001 + 1e-6
    for c in ("AU01", "AU06", "AU45"):
        assert np.abs(back[c] - track[c]).max() <= 0.001 + 1e-6  # 2 decimals on 0–5


def test_arkit_livelink_roundtrip(tmp_path, track):
    p = write_track(track, tmp_path / "ll.csv", format="arkit")
    lines = p.read_text().splitlines()
    assert lines[0].startswith("Timecode,BlendShapeCount,EyeBlinkLeft,EyeLookDownLeft")
    assert lines[0].endswith("RightEyeYaw,RightEyePitch,RightEyeRoll")
    assert lines[1].startswith("00:00:00:00.000,61,") and lines[2].startswith("00:00:00:02.000")
    back = read_track(p)
    assert detect_format(p) == "arkit" and back.fps == 30.0
    for c in PRIMARY:
        want = track[c] if c != "AU12" else track["AU12"]
        if c == "AU12L":
            continue
        assert np.abs(back[c] - want).max() <= 1e-6, c
    # a one-sided smile comes back one-sided
    assert np.abs(back["AU12L"] - np.clip(track["AU12"] + track["AU12L"], 0, 1) +
                  back["AU12"]).max() <= 1e-6


def test_head_rotation_survives_livelink(tmp_path):
    tr = AUTrack(np.array([[0.5, 0.0, 0.2], [0.0, 0.4, 0.0]]), ("AU51", "AU52", "AU54"), 30)
    back = read_track(write_track(tr, tmp_path / "h.csv", format="arkit"))
    assert back["AU51"][0] == pytest.approx(0.5, abs=1e-6)
    assert back["AU52"][1] == pytest.approx(0.4, abs=1e-6)
    assert back["AU54"][0] == pytest.approx(0.2, abs=1e-6)


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
