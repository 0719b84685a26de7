"""The command line as a user meets it: listings, images, and one-line errors with exit code 2."""

import json
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from mimika.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_aus_lists_every_au_with_what_models_it(capsys):
    code, out, _ = run(capsys, "aus", "--json")
    rows = {r["code"]: r for r in json.loads(out)}
    assert code == 0 and len(rows) == 58
    assert rows["AU12"]["name"] == "Lip Corner Puller" and rows["AU12"]["builtin"]
    assert rows["AU12"]["sides"] == ["AU12L", "AU12R"]
    assert rows["AU51"]["objects"] == ["face", "eyes", "teeth"]
    assert rows["AU51"]["kind"] == "rotation"
    assert not rows["AU19"]["builtin"]  # tongue show: not modelled
    code, out, _ = run(capsys, "aus")
    assert "AU27  Mouth Stretch" in out


def test_unknown_au_is_one_line_with_suggestions(capsys):
    code, out, err = run(capsys, "pose", "--au", "AU3=1", "-o", "x.png")
    assert code == 2 and out == ""
    assert err.strip().splitlines() == [
        "mimika: error: unknown Action Unit 'AU3'; did you mean AU02, AU04, AU01? "
        "(run 'mimika aus' for the full list)"]


@pytest.mark.parametrize(("argv", "message"), [
    (["pose", "--au", "AU12=1.2", "-o", "x.png"], "AU12=1.2 is outside [0, 1]"),
    (["pose", "--au", "AU12=1", "-o", "x.jpg"], "must be a .png file"),
    (["pose", "--head", "nohead", "-o", "x.png"], "unknown head 'nohead'"),
    (["pose", "--expression", "happines", "-o", "x.png"], "did you mean"),
])
def test_bad_input_exit_code_2(capsys, argv, message):
    code, _, err = run(capsys, *argv)
    assert code == 2 and message in err and "Traceback" not in err


def test_typo_in_command_suggests_the_right_one():
    r = subprocess.run([sys.executable, "-m", "mimika", "pos"], capture_output=True, text=True)
    assert r.returncode == 2 and "did you mean 'pose'?" in r.stderr


def test_missing_ict_data_says_how_to_get_it(capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("MIMIKA_ICT_DIR", str(tmp_path / "nowhere"))
    code, _, err = run(capsys, "pose", "--head", "ict", "--au", "AU12", "-o", "x.png")
    assert code == 2 and "ICT-FaceKit" in err and "MIMIKA_ICT_DIR" in err


@pytest.mark.render
def test_pose_writes_a_png_where_the_smile_changes_the_mouth(capsys, tmp_path, builtin_rig):
    neutral, smile = tmp_path / "n.png", tmp_path / "s.png"
    assert run(capsys, "pose", "--size", "320x240", "-o", str(neutral))[0] == 0
    assert run(capsys, "pose", "--au", "AU12=1", "--au", "6=0.7", "--size", "320x240",
               "-o", str(smile))[0] == 0
    a = np.asarray(Image.open(neutral), np.int16)
    b = np.asarray(Image.open(smile), np.int16)
    assert a.shape == (240, 320, 3)
    from mimika.render import Renderer

    with Renderer(builtin_rig.head, size=(320, 240)) as r:
        cam = r.camera("front")
    mouth = cam.project(builtin_rig.head.landmark_points()[[48, 54, 51, 57]], (320, 240))
    (x0, y0), (x1, y1) = mouth.min(0).astype(int) - 12, mouth.max(0).astype(int) + 12
    diff = np.abs(a - b).sum(2)
    assert diff[y0:y1, x0:x1].mean() > 5 * max(diff[:40].mean(), 0.05)  # mouth, not the top


@pytest.mark.render
def test_pose_expression_and_grid(capsys, tmp_path):
    out = tmp_path / "happy.png"
    assert run(capsys, "pose", "--expression", "happiness", "--intensity", "0.7",
               "--size", "160x120", "-o", str(out))[0] == 0
    assert Image.open(out).size == (160, 120)
    sheet = tmp_path / "sheet.png"
    assert run(capsys, "pose", "--grid", "--columns", "6", "-q", "-o", str(sheet))[0] == 0
    w, h = Image.open(sheet).size
    assert w >= 6 * 200 and h > w / 2  # ≥ 36 tiles in 6 columns


def test_pose_face_height_out_of_range_is_one_line_with_exit_2(capsys, tmp_path):
    code, _, err = run(capsys, "pose", "--face-height", "1.5", "-o", str(tmp_path / "x.png"))
    assert code == 2 and "--face-height 1.5" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.png").exists()
