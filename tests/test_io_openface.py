"""OpenFace 2 CSV: RecorderCSV's exact columns and number formats, a name-based reader's view,
pose and gaze both ways, a real OpenFace file, and files already normalised to 0–1."""

import csv
import re

import numpy as np
import pytest

from conftest import PYFEAT_DIR, needs_pyfeat
from mimika.errors import DataError
from mimika.io.openface import OPENFACE_AUS, OPENFACE_PRESENCE
from mimika.io.tracks import read_track, write_track
from mimika.tracks import AUTrack

EYE_LANDMARKS = 56  # OpenFace's eye model (num_eye_landmarks)


def recorder_csv_header(*, gaze: bool, pose: bool) -> list[str]:
    """OpenFace's RecorderCSV::Open for a sequence with -aus (and -gaze, -pose): the columns
    in its order; AU names sorted as it sorts them."""
    cols = ["frame", "face_id", "timestamp", "confidence", "success"]
    if gaze:
        cols += ["gaze_0_x", "gaze_0_y", "gaze_0_z", "gaze_1_x", "gaze_1_y", "gaze_1_z",
                 "gaze_angle_x", "gaze_angle_y"]
        for axis in ("x", "y", "X", "Y", "Z"):
            cols += [f"eye_lmk_{axis}_{i}" for i in range(EYE_LANDMARKS)]
    if pose:
        cols += ["pose_Tx", "pose_Ty", "pose_Tz", "pose_Rx", "pose_Ry", "pose_Rz"]
    cols += [f"{a}_r" for a in sorted(OPENFACE_AUS)]
    cols += [f"{a}_c" for a in sorted(OPENFACE_PRESENCE)]
    return cols


#: RecorderCSV::WriteLine's number formats (std::fixed with these precisions)
FORMATS = {"frame": r"\d+", "face_id": r"\d+", "timestamp": r"\d+\.\d{3}",
           "confidence": r"\d\.\d{2}", "success": r"[01]", "gaze_": r"-?\d\.\d{6}",
           "gaze_angle": r"-?\d+\.\d{3}", "pose_T": r"-?\d+\.\d", "pose_R": r"-?\d+\.\d{3}",
           "_r": r"\d\.\d{2}", "_c": r"[01]\.0"}


def name_based_read(path) -> dict[str, np.ndarray]:
    """How OpenFace CSVs are read by name (py-feat's read_openface: pandas read_csv, column
    names stripped of the spaces after RecorderCSV's ', ')."""
    with open(path, encoding="utf-8") as f:
        rows = list(csv.reader(f))
    head = [h.strip() for h in rows[0]]
    return {h: np.array([float(r[j]) for r in rows[1:]]) for j, h in enumerate(head)}


@pytest.fixture
def face_track():
    t = np.linspace(0, 2, 51)[:, None]
    face = ("AU01", "AU06", "AU12", "AU12L", "AU25", "AU45", "AU11", "AU28")
    head = ("AU52", "AU54", "AU55", "AU61", "AU63")  # one of each pair: a net angle
    chans = face + head
    vals = 0.5 + 0.45 * np.sin(2 * np.pi * (0.6 * t + np.linspace(0, 1, len(chans))))
    vals[:, len(face):] *= 0.6
    return AUTrack(np.clip(vals, 0, 1), chans, 25)


def test_columns_and_number_formats_are_recorder_csv(tmp_path, face_track):
    p = write_track(face_track, tmp_path / "of.csv", format="openface")
    lines = p.read_text().splitlines()
    head = lines[0].split(", ")
    full = recorder_csv_header(gaze=True, pose=True)
    assert head == [c for c in full if not c.startswith("eye_lmk_")]  # no image landmarks
    assert "AU11_r" not in head and "AU28_r" not in head and "AU28_c" in head
    for line in lines[1:]:
        cells = line.split(", ")
        assert len(cells) == len(head)
        for name, cell in zip(head, cells, strict=True):
            key = next(k for k in ("gaze_angle", "gaze_", "pose_T", "pose_R", "_r", "_c")
                       if k in name) if name not in FORMATS else name
            assert re.fullmatch(FORMATS[key], cell), (name, cell)
    aus_only = write_track(face_track, tmp_path / "aus.csv", format="openface", gaze=False,
                           pose=False)
    assert aus_only.read_text().splitlines()[0].split(", ") == \
        recorder_csv_header(gaze=False, pose=False)  # exactly FeatureExtraction -aus


def test_round_trip_per_channel(tmp_path, face_track):
    p = write_track(face_track, tmp_path / "of.csv", format="openface")
    named = name_based_read(p)
    folded12 = np.clip(face_track["AU12"] + face_track["AU12L"] / 2, 0, 1)
    assert np.abs(named["AU12_r"] / 5 - folded12).max() <= 0.001 + 1e-6
    assert np.allclose(named["pose_Ry"], np.radians(35) * face_track["AU52"], atol=5e-4)
    back = read_track(p)
    assert back.fps == 25 and back.meta["scale"] == 5
    for c in ("AU01", "AU06", "AU25", "AU45"):  # 2 decimals on 0–5
        assert np.abs(back[c] - face_track[c]).max() <= 0.001 + 1e-6, c
    for c in ("AU52", "AU54", "AU55"):  # radians with 3 decimals
        assert np.abs(back[c] - face_track[c]).max() <= 0.0015, c
    for c in ("AU61", "AU63"):  # gaze (3 decimals) minus the head (3 decimals)
        assert np.abs(back[c] - face_track[c]).max() <= 0.003, c
    for c in ("AU51", "AU53", "AU56", "AU62", "AU64"):
        assert back[c].max() <= 0.003, c


@needs_pyfeat
def test_real_openface_file_replays_head_turns_and_eye_movements(tmp_path):
    src = PYFEAT_DIR / "tests_data" / "OpenFace_Test.csv"
    tr = read_track(src)
    named = name_based_read(src)
    assert tr.meta["scale"] == 5 and tr.meta["pose"] and tr.meta["gaze"]
    assert np.allclose(tr["AU01"], named["AU01_r"] / 5, atol=1e-6)
    ry = named["pose_Ry"]  # + turns to the subject's right (AU52), − to the left (AU51)
    assert np.allclose(tr["AU51"] - tr["AU52"], -ry / np.radians(35), atol=1e-5)
    assert np.allclose(tr["AU54"], named["pose_Rx"] / np.radians(25), atol=1e-5)
    assert np.ptp(tr["AU51"] - tr["AU52"]) > 0.05  # the head turns …
    eyes_x = tr["AU62"] - tr["AU61"]
    assert np.ptp(eyes_x) > 0.05 and np.ptp(tr["AU63"] - tr["AU64"]) > 0.05  # … eyes move
    out = tmp_path / "of.glb"
    from mimika.cli import main

    assert main(["replay", str(src), "-o", str(out), "--take-fps", "30", "-q"]) == 0
    assert out.stat().st_size > 10_000


@needs_pyfeat
def test_normalised_file_is_not_divided_by_five_again(tmp_path):
    src = PYFEAT_DIR / "tests_data" / "OpenFace_Test.csv"
    with open(src, encoding="utf-8") as f:
        rows = list(csv.reader(f))
    head = [h.strip() for h in rows[0]]
    rcols = [j for j, h in enumerate(head) if h.endswith("_r")]
    for r in rows[1:]:  # FACSvatar-style: intensities divided by 5 (3 decimals)
        for j in rcols:
            r[j] = f"{float(r[j]) / 5:.3f}"
    norm = tmp_path / "norm.csv"
    with open(norm, "w", newline="", encoding="utf-8") as f:
        csv.writer(f).writerows(rows)
    real = read_track(src)
    tr = read_track(norm)
    assert tr.meta["scale"] == 1 and any("already normalised" in n for n in tr.meta["notes"])
    assert np.abs(tr["AU01"] - real["AU01"]).max() <= 0.0006
    assert np.allclose(read_track(norm, scale="5")["AU01"], real["AU01"] / 5, atol=0.0002)
    with pytest.raises(DataError, match=r"reach 1\.4.*drop --scale 1"):
        read_track(src, scale="1")


def test_calm_openface_output_stays_on_the_0_5_scale(tmp_path):
    calm = AUTrack(np.full((10, 2), 0.1), ("AU12", "AU06"), 30)  # _r 0.50: every value ≤ 1
    back = read_track(write_track(calm, tmp_path / "calm.csv", format="openface"))
    assert back.meta["scale"] == 5 and np.allclose(back["AU12"], 0.1)
    assert "2 decimals" in back.meta["notes"][0]


def test_body_channels_have_no_openface_column(tmp_path):
    tr = AUTrack(np.full((4, 2), 0.5), ("AU12", "body.breath"), 30)
    p = write_track(tr, tmp_path / "b.csv", format="openface")
    assert "body" not in p.read_text() and np.allclose(read_track(p)["AU12"], 0.5)
