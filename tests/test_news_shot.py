"""The newsreader's broadcast shot: HD 16:9 by default, a TV medium close-up of characters (head
a third of the height, eyes on the upper third line), ``--shot``, the ``--title`` name strap."""

import numpy as np
import pytest
from tests.test_news import TEXT, run_cli

from mimika.newsreader.pipeline import DEFAULT_SIZE, SHOTS, news_camera


def test_the_default_video_is_hd_16_9():
    from mimika.cli import build_parser

    args = build_parser().parse_args(["news", "--example", "en", "-o", "x.mp4"])
    assert args.size == DEFAULT_SIZE == (1280, 720)
    assert args.shot == "medium"


def _head_box(head, cam, size):
    """Top, bottom (image rows) of the head (crown to chin: the projected skin vertices at or
    above the chin) and the eyes' row."""
    from mimika.render.camera import head_points

    p = cam.project(head_points(head), size)
    eyes = cam.project(head.landmark_points()[36:48], size)[:, 1].mean()
    return p[:, 1].min(), p[:, 1].max(), eyes


@pytest.mark.parametrize("shot", list(SHOTS))
def test_a_character_fills_the_shot_as_stated(character_rig, shot):
    head = character_rig.head
    w, h = DEFAULT_SIZE
    cam = news_camera(head, "front", w / h, shot)
    top, bottom, eyes = _head_box(head, cam, (w, h))
    share = (bottom - top) / h
    assert abs(share - SHOTS[shot]["head"]) < 0.1 * SHOTS[shot]["head"], share
    assert abs(eyes / h - SHOTS[shot]["eye_line"]) < 0.02
    assert top > 0.03 * h  # headroom: the crown is in the frame
    if shot == "medium":  # shoulders in: the clothes reach the frame's sides' inner half
        cl = cam.project(head["clothes"].vertices, (w, h))
        seen = (cl[:, 1] > bottom) & (cl[:, 1] < h)
        assert np.ptp(cl[seen, 0]) > 0.3 * w


def test_the_bare_head_keeps_a_centred_close_up(builtin_rig):
    head = builtin_rig.head
    cam = news_camera(head, "front", 16 / 9)
    top, bottom, _ = _head_box(head, cam, (1280, 720))
    assert 0.5 < (bottom - top) / 720 < 0.95
    assert abs((top + bottom) / 2 / 720 - 0.5) < 0.12


@pytest.mark.parametrize(("argv", "msg"), [
    (["--shot", "huge"], "invalid choice: 'huge'"),
    (["--title", ""], "title is empty"),
    (["--title", "x" * 150], "at most 100"),
    (["--title", "Anna\tSmith"], "control characters"),
    (["--title", "日本のニュース"], "cannot draw"),
    (["--title", "Wolfgang Amadeus " * 5, "--size", "160x120"], "too long"),
])
def test_bad_shot_or_title_is_one_line_and_exit_2(tmp_path, capsys, argv, msg):
    (tmp_path / "a.txt").write_text("Hello.", "utf-8")
    out = tmp_path / "out"
    try:
        rc = run_cli(["news", str(tmp_path / "a.txt"), "-o", str(out / "n.mp4"), *argv])
    except SystemExit as e:  # argparse refuses the option itself
        rc = e.code
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mimika: error:") and msg in err[0], err
    assert not out.exists() or not any(out.iterdir())


def test_the_strap_fades_in_and_out_in_the_lower_third():
    from mimika.render.video import TitleStrap

    s = TitleStrap("Amara Okafor — News at Nine", (1280, 720))
    x0, y0, x1, y1 = s.box
    assert y0 > 720 * 2 / 3 - 40 and y1 < 720 * 0.915  # lower third, above the desk
    assert s.opacity(0.0) == 0.0 and s.opacity(3.0) == 1.0 and s.opacity(30.0) == 0.0
    frame = np.full((720, 1280, 3), 90, np.uint8)
    assert s(frame, 0.0) is frame
    out = s(frame, 3.0)
    assert (out != 90).any(axis=2)[y0:y1, x0:x1].mean() > 0.9
    assert (out[:y0] == 90).all() and (out[y1:] == 90).all()


@pytest.mark.parametrize("size", [(1280, 720), (640, 480), (854, 480)])
def test_the_strap_keeps_its_colours_through_h264(tmp_path, size):
    """H.264 keeps one colour sample per 2×2 pixels: a strap edge inside a pair (the accent
    stripe ended on an odd row at 720p) came out of the encoder as a grey line under the
    orange stripe. Every edge now lies on the grid, so each of the strap's rows keeps its
    colour in the video."""
    import av

    from mimika.render.video import TitleStrap, VideoWriter

    w, h = size
    s = TitleStrap("Amara Okafor — News at Nine", size)
    x0, y0, _, y1 = s.box
    assert all(v % 2 == 0 for v in s.box)
    frame = s(np.full((h, w, 3), 20, np.uint8), 3.0)
    with VideoWriter(tmp_path / "s.mp4", fps=25, size=size, crf=12) as vw:
        for _ in range(3):
            vw.write(frame)
    with av.open(str(tmp_path / "s.mp4")) as c:
        got = next(iter(c.decode(video=0))).to_ndarray(format="rgb24").astype(int)
    accent = frame[y0:y1, x0:x0 + 4].astype(int)
    err = np.abs(got[y0:y1, x0:x0 + 4] - accent).max(axis=(1, 2))  # per row of the stripe
    assert err.max() < 40, f"rows {np.flatnonzero(err >= 40) + y0} of the stripe discoloured"


@pytest.mark.render
def test_the_title_strap_is_in_the_video_frames(tmp_path, builtin_rig):
    import av

    from mimika.newsreader import render_news

    out = tmp_path / "t.mp4"
    title = "Amara Okafor — News at Nine"
    render_news(TEXT, out=out, size=(320, 180), rig=builtin_rig, workers=1, subtitles=False,
                title=title)
    plain = tmp_path / "p.mp4"
    render_news(TEXT, out=plain, size=(320, 180), rig=builtin_rig, workers=1, subtitles=False)

    def frame_at(path, t):
        with av.open(str(path)) as c:
            for f in c.decode(video=0):
                if f.time >= t:
                    return f.to_ndarray(format="rgb24").astype(int)
        raise AssertionError(f"no frame at {t} s")

    from mimika.render.video import TitleStrap

    x0, y0, x1, y1 = TitleStrap(title, (320, 180)).box
    assert y0 >= 180 * 0.6 and y1 < 180 * 0.92  # the lower third, above the desk
    diff = np.abs(frame_at(out, 3.0) - frame_at(plain, 3.0)).sum(axis=2) > 40
    inside = np.zeros_like(diff)
    inside[y0:y1, x0:x1] = True
    assert diff[inside].mean() > 0.3
    assert diff[~inside].mean() < 0.01
    assert (np.abs(frame_at(out, 0.0) - frame_at(plain, 0.0)).sum(axis=2) > 40).mean() < 0.001


def test_cli_passes_shot_and_title(monkeypatch, tmp_path):
    import mimika.newsreader as nr

    seen = {}

    def fake(article, **kw):
        seen.update(kw)
        raise SystemExit(0)

    monkeypatch.setattr(nr, "render_news", fake)
    (tmp_path / "a.txt").write_text("Hello.", "utf-8")
    with pytest.raises(SystemExit):
        run_cli(["news", str(tmp_path / "a.txt"), "-o", str(tmp_path / "n.mp4"),
                 "--shot", "wide", "--title", "Ann Lee — Late News"])
    assert seen["shot"] == "wide" and seen["title"] == "Ann Lee — Late News"
    assert seen["size"] == (1280, 720)
