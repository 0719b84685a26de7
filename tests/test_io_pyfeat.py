"""py-feat Detector output: real clips replayed from blendshapes or AUs, the video's frame rate
from approx_time, several faces, frames without a face, and bad cells."""

import csv

import numpy as np
import pytest

from conftest import PYFEAT_DIR, needs_pyfeat
from mimika.errors import DataError
from mimika.io.pyfeat import read_pyfeat_csv, video_fps_from_times
from mimika.io.tracks import detect_format, read_track


def columns(path) -> dict[str, list[str]]:
    with open(path, encoding="utf-8") as f:
        rows = list(csv.reader(f))
    return {h: [r[j] for r in rows[1:]] for j, h in enumerate(rows[0])}


def fcol(cols, name):
    return np.array([float(x) for x in cols[name]])


@needs_pyfeat
@pytest.mark.parametrize("clip", [f"{i:03d}" for i in range(1, 21)])
def test_every_news_clip_reads_at_the_videos_rate(clip):
    p = PYFEAT_DIR / "news_sample" / f"{clip}.csv"
    assert detect_format(p) == "pyfeat"
    tr = read_track(p)
    assert tr.meta["video_fps"] == 25 and tr.meta["frame_step"] == 2 and tr.fps == 12.5
    cols = columns(p)
    assert tr.n_frames == len(cols["frame"])  # one row per processed frame, none missing
    assert tr.values.min() >= 0 and tr.values.max() <= 1


@needs_pyfeat
def test_blendshapes_and_aus_drive_the_head_as_py_feat_saw_it():
    p = PYFEAT_DIR / "news_sample" / "012.csv"
    cols = columns(p)
    yaw, pitch, roll = (fcol(cols, c) for c in ("Yaw", "Pitch", "Roll"))
    bs = read_pyfeat_csv(p)
    smile_l, smile_r = fcol(cols, "mouthSmileLeft"), fcol(cols, "mouthSmileRight")
    assert np.allclose(bs["AU12"], np.minimum(smile_l, smile_r), atol=1e-6)
    rest = smile_l - np.minimum(smile_l, smile_r)  # a one-sided smile stays one-sided
    assert np.allclose(bs["AU12L"] if "AU12L" in bs.channels else 0 * rest, rest, atol=1e-6)
    for pos, neg, angle, deg in (("AU52", "AU51", yaw, 35), ("AU54", "AU53", pitch, 25),
                                 ("AU56", "AU55", roll, 25)):  # intensity 1 at deg degrees
        want = np.clip(angle / np.radians(deg), -1, 1)
        assert np.allclose(bs[pos] - bs[neg], want, atol=1e-6), pos
    down = (fcol(cols, "eyeLookDownLeft") + fcol(cols, "eyeLookDownRight")) / 2
    assert np.allclose(bs["AU64"], down, atol=1e-6)  # gaze from the eyeLook shapes
    assert "MouthClose" in bs.meta["arkit_extra"]  # kept for a Live Link export
    au = read_pyfeat_csv(p, source="aus")
    assert np.allclose(au["AU12"], fcol(cols, "AU12"), atol=1e-6)
    assert np.allclose(au["AU43"], fcol(cols, "AU43"), atol=1e-6)
    eye_down = (fcol(cols, "gaze_pitch") - pitch) / np.radians(30)  # eye in head
    assert np.allclose(au["AU64"] - au["AU63"], np.clip(eye_down, -1, 1), atol=1e-6)
    assert np.ptp(au["AU64"] - au["AU63"]) > 0.3  # the look down in this clip


@needs_pyfeat
def test_replay_cli_takes_py_feat(tmp_path):
    from mimika.cli import main

    p = PYFEAT_DIR / "news_sample" / "001.csv"
    assert main(["replay", str(p), "-o", str(tmp_path / "a.glb"), "-q"]) == 0
    assert main(["replay", str(p), "--from", "aus", "-o", str(tmp_path / "a.csv"), "-q"]) == 0
    assert read_track(tmp_path / "a.csv").fps == 12.5
    assert main(["replay", str(p), "--take-fps", "30", "-o", str(tmp_path / "b.csv"),
                 "-q"]) == 0
    assert read_track(tmp_path / "b.csv").fps == 15


def test_video_rate_from_approx_time():
    assert video_fps_from_times(np.array([0, 24, 26, 50]), np.array([0, 0, 1, 2]))[0] == 25
    assert video_fps_from_times(np.array([0, 28, 30]), np.array([0, 0, 1]))[0] == 29.97
    assert video_fps_from_times(np.array([0, 10]), np.array([0, 0]))[0] == 30  # only > 10


HEADER = ["FaceRectX", "FaceRectY", "FaceRectWidth", "FaceRectHeight", "FaceScore", "Pitch",
          "Roll", "Yaw", "AU12", "gaze_pitch", "gaze_yaw", "mouthSmileLeft", "mouthSmileRight",
          "input", "frame", "approx_time"]


def fex(tmp_path, rows, name="f.csv"):
    p = tmp_path / name
    with open(p, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(HEADER)
        for r in rows:
            w.writerow([r.get(h, "") for h in HEADER])
    return p


def face(frame, smile, *, w=100.0, yaw=0.0, score=0.99):
    return {"FaceRectX": 0, "FaceRectY": 0, "FaceRectWidth": w, "FaceRectHeight": w,
            "FaceScore": score, "Pitch": 0.0, "Roll": 0.0, "Yaw": yaw, "AU12": smile,
            "gaze_pitch": 0.0, "gaze_yaw": 0.0, "mouthSmileLeft": smile,
            "mouthSmileRight": smile, "input": "v.mp4", "frame": frame, "approx_time": "00:00"}


def test_largest_face_and_frames_without_a_face(tmp_path):
    rows = [face(0, 0.2), face(0, 0.9, w=300), face(1, 0.4),
            {"input": "v.mp4", "frame": 2, "approx_time": "00:00"},  # no face found
            face(3, 0.8)]
    tr = read_pyfeat_csv(fex(tmp_path, rows), fps=30)
    assert tr.n_frames == 4 and tr.fps == 30
    assert np.allclose(tr["AU12"], [0.9, 0.4, 0.6, 0.8], atol=1e-6)  # frame 2 filled
    assert tr.meta["dropouts"] == 1 and "several faces" in tr.meta["notes"][0]


def test_angles_in_degrees_are_recognised(tmp_path):
    tr = read_pyfeat_csv(fex(tmp_path, [face(0, 0.1, yaw=20.0), face(1, 0.1, yaw=-10.0)]),
                         fps=30)
    assert tr["AU52"][0] == pytest.approx(20 / 35, abs=1e-5)
    assert "degrees" in tr.meta["notes"][-1]


@pytest.mark.parametrize("change, message", [
    ({"Yaw": "high"}, r"f.csv:2:Yaw: 'high' is not a number"),
    ({"mouthSmileLeft": "7"}, r"f.csv:2:mouthSmileLeft: 7 is outside \[0, 1\]"),
    ({"frame": "-3"}, r"f.csv:2:frame: '-3' is not a frame number"),
    ({"approx_time": "soon"}, r"f.csv:2:approx_time: 'soon' is not MM:SS"),
    ({"FaceScore": "inf"}, r"f.csv:2:FaceScore: 'inf' is not a finite number"),
])
def test_bad_cells_name_line_and_column(tmp_path, change, message):
    with pytest.raises(DataError, match=message):
        read_pyfeat_csv(fex(tmp_path, [{**face(0, 0.2), **change}, face(1, 0.3)]))
