"""Live Link Face / OpenFace import and replay; the CLI commands of mimika.commands.timeline."""

import numpy as np
import pytest

from conftest import MOTION_DIR as MOTION
from conftest import needs_motion
from mimika.io.tracks import read_livelink_csv, read_track


@pytest.fixture
def cli(monkeypatch, capsys):
    import mimika.cli as c

    if "timeline" not in c.MODULES:
        monkeypatch.setattr(c, "MODULES", (*c.MODULES, "timeline"))

    def run(*argv):
        code = c.main([str(a) for a in argv])
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


@needs_motion
def test_livelink_dropouts_filled_at_30fps():
    tr = read_livelink_csv(MOTION / "S88-001.csv")
    assert tr.fps == 30.0
    assert tr.meta["dropouts"] == 277 and tr.meta["filled"] >= 277
    assert tr.n_frames == 1942  # 1939 rows + 3 missing rows on the 30 fps grid
    assert np.all(np.isfinite(tr.values)) and tr.values.min() >= 0 and tr.values.max() <= 1
    # filled frames are interpolated: no jumps to 0 where the tracker dropped out
    jaw = tr["AU27"]
    assert np.abs(np.diff(jaw)).max() < 0.5
    assert {"AU12", "AU45", "AU61", "AU64"} <= set(tr.channels)


@needs_motion
def test_replay_cli_glb_and_csv(tmp_path, cli):
    take = MOTION / "apfel.csv"
    code, out, err = cli("replay", take, "-o", tmp_path / "take.csv", "--fps", "10")
    assert code == 0 and "wrote" in out and "drop-out rows filled" in err
    back = read_track(tmp_path / "take.csv")
    assert back.fps == 10.0
    code, out, err = cli("replay", take, "-o", tmp_path / "take.glb", "--fps", "5")
    assert code == 0 and (tmp_path / "take.glb").stat().st_size > 10_000


def test_replay_png_contact_strip(tmp_path, cli):
    pytest.importorskip("moderngl")
    from mimika.render.context import egl_available

    if not egl_available():
        pytest.skip("no headless OpenGL (Mesa EGL)")
    from mimika.io.tracks import write_track
    from mimika.tracks import AUTrack

    tr = AUTrack(np.linspace(0, 1, 10)[:, None] * [1.0, 0.5], ("AU12", "AU26"), 10)
    write_track(tr, tmp_path / "t.csv")
    code, _, _ = cli("replay", tmp_path / "t.csv", "-o", tmp_path / "t.png", "--frames", "3",
                       "--size", "64x48")
    assert code == 0 and (tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"


def test_render_plot_project_cli(tmp_path, cli):
    script = tmp_path / "s.xml"
    script.write_text('<speak><m:expr name="happiness" intensity="0.5">Hello there</m:expr>. '
                      '<m:blink/>Bye!</speak>')
    for out in ("o.csv", "o.json", "o.xml"):
        code, msg, err = cli("render", script, "-o", tmp_path / out)
        assert code == 0, err
    code, msg, _ = cli("render", script, "-o", tmp_path / "of.csv", "--format", "openface")
    assert code == 0 and "openface CSV" in msg
    code, msg, _ = cli("project", "check", tmp_path / "o.json")
    assert code == 0 and "ok" in msg
    code, msg, _ = cli("render", tmp_path / "o.json", "-o", tmp_path / "again.csv")
    assert code == 0
    assert (tmp_path / "again.csv").read_text() == (tmp_path / "o.csv").read_text()
    code, msg, _ = cli("plot", script, "-o", tmp_path / "c.png", "--aus", "AU12,AU45")
    assert code == 0 and (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG"
    code, msg, _ = cli("plot", tmp_path / "o.csv", "-o", tmp_path / "c2.png")
    assert code == 0


def test_cli_errors_are_one_line(tmp_path, cli):
    bad = tmp_path / "bad.xml"
    bad.write_text("<speak>\n  <m:expr name='happiness'>hi</m:exp>\n</speak>")
    code, _, err = cli("render", bad, "-o", tmp_path / "x.csv")
    assert code == 2 and f"{bad}:2:" in err and "mismatched tag" in err
    assert len(err.strip().splitlines()) == 1
    code, _, err = cli("render", bad, "-o", tmp_path / "x.mp3")
    assert code == 2
    assert not (tmp_path / "x.csv").exists()
    csv = tmp_path / "t.csv"
    csv.write_text("time,AU12\n0,0.5\n0.1,x\n")
    code, _, err = cli("replay", csv, "-o", tmp_path / "y.csv")
    assert code == 2 and "t.csv:3:AU12" in err


def test_cli_reports_where_the_animation_ends(tmp_path, cli):
    from mimika.io.tracks import write_track
    from mimika.tracks import AUTrack

    write_track(AUTrack(np.linspace(0, 1, 121)[:, None], ("AU12",), 25), tmp_path / "t.csv")
    code, out, _ = cli("replay", tmp_path / "t.csv", "-o", tmp_path / "t.glb")
    assert code == 0 and "121 frames at 25 fps, 0–4.80 s" in out  # not 4.84 s
    assert "set 25 fps before importing, frames 0–120" in out


def test_cli_replay_options_and_broken_takes(tmp_path, cli):
    from mimika.io.arkit import LIVELINK_COLUMNS

    zeros = ",".join(["0.1"] * (len(LIVELINK_COLUMNS) - 2))
    take = tmp_path / "t.csv"
    take.write_text(",".join(LIVELINK_COLUMNS) + "\n" + "".join(
        f"00:00:00:{f:02d}.000,61,{zeros}\n" for f in (40, 44, 42, 46)))
    code, _, err = cli("replay", take, "-o", tmp_path / "x.csv")
    assert code == 2 and "t.csv:4:Timecode: not after line 3" in err
    assert len(err.strip().splitlines()) == 1
    code, _, err = cli("replay", take, "-o", tmp_path / "x.csv", "--timecodes", "repair")
    assert code == 0 and "timecodes repaired: 2 rows moved" in err
    code, _, err = cli("replay", take, "-o", tmp_path / "x.csv", "--scale", "1")
    assert code == 2 and "--scale does not apply to Live Link Face files" in err
