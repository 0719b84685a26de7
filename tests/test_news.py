"""The newsreader end to end: MP4 + SRT, sync, lips, switches, bad input (``mimika news``)."""

import argparse
import itertools
import math
import sys
import time

import numpy as np
import pytest

from mimika.newsreader import (
    ABLATIONS,
    FEATURES,
    news_track,
    parse_article,
    parse_srt,
    sentence_cues,
    speak_article,
)

TEXT = ("Good evening. The council approved a budget of 12 million euros.\n\n"
        "Will it be enough? Goodbye.")
FPS = 25.0


def run_cli(argv: list[str]) -> int:
    """``mimika`` with the news command (registered here if the CLI does not list it yet)."""
    from mimika.cli import _Parser
    from mimika.commands import MODULES
    from mimika.errors import MimikaError

    if "news" in MODULES:
        from mimika.cli import main

        return main(argv)
    import mimika.commands.news as news

    p = _Parser(prog="mimika")
    p.add_argument("--debug", action="store_true")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    news.register(sub)
    args: argparse.Namespace = p.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except MimikaError as e:
        print(f"mimika: error: {e}", file=sys.stderr)
        return 2


@pytest.fixture(scope="module")
def spoken():
    art = parse_article(TEXT)
    return art, *speak_article(art, lang="en")


@pytest.fixture(scope="module")
def video(tmp_path_factory, spoken):
    d = tmp_path_factory.mktemp("news")
    (d / "article.txt").write_text(TEXT, "utf-8")
    out = d / "news.mp4"
    rc = run_cli(["news", str(d / "article.txt"), "-o", str(out), "--size", "160x120",
                  "--aus", str(d / "news.csv"), "--quiet"])
    assert rc == 0
    return out


def test_article_parsing_plain_and_script():
    art = parse_article("One.  Two.\n\n\nThree.\n")
    assert art.paragraphs == ("One. Two.", "Three.") and art.script is None
    s = parse_article("<speak>Hello <expression name='happiness' dur='1'>there</expression>."
                      "</speak>")
    assert s.script is not None and s.paragraphs == ("Hello there.",)


def test_speech_has_newsreader_pauses_and_tiles_the_audio(spoken):
    _, utt, paras = spoken
    assert len(utt.sentences) == 4 and len(paras) == 2
    assert paras[0] == pytest.approx(utt.sentences[0].start)
    assert paras[1] == pytest.approx(utt.sentences[2].start)
    ph = utt.phonemes
    assert ph[0].start == 0 and ph[-1].end == pytest.approx(utt.duration)
    assert all(abs(a.end - b.start) < 1e-9 for a, b in itertools.pairwise(ph))
    w = utt.words
    gap = [b.start - a.end for a, b in itertools.pairwise(w)]
    assert max(gap) >= 0.6  # the paragraph pause


@pytest.mark.render
def test_video_decodes_as_h264_aac_with_matching_durations(video, spoken):
    from mimika.render.video import probe

    info = probe(video)
    assert info["video_codec"] == "h264" and info["audio_codec"] == "aac"
    assert (info["width"], info["height"]) == (160, 120) and info["fps"] == FPS
    _, utt, _ = spoken
    assert info["n_frames"] == math.ceil(utt.duration * FPS - 1e-9)
    assert abs(info["video_duration"] - utt.duration) <= 1 / FPS
    import av

    with av.open(str(video)) as c:
        a = c.streams.audio[0]
        adur = float(a.duration * a.time_base)
    assert abs(adur - info["video_duration"]) <= 1 / FPS


@pytest.mark.render
def test_srt_beside_the_video_has_one_cue_per_sentence(video, spoken):
    srt = video.with_suffix(".srt")
    cues = parse_srt(srt.read_text("utf-8"))
    _, utt, _ = spoken
    assert [c.text for c in cues] == [s.text for s in utt.sentences]
    for c, s in zip(cues, utt.sentences, strict=True):
        words = [w for w in utt.words if s.start <= w.start < s.end]
        assert c.start == pytest.approx(words[0].start, abs=0.002)
        assert words[-1].end - 0.002 <= c.end <= words[-1].end + 0.4
    assert all(a.end <= b.start for a, b in itertools.pairwise(cues))
    assert sentence_cues(utt)[0].text == "Good evening."


@pytest.mark.render
def test_au_csv_is_exported_with_one_row_per_frame(video):
    from mimika.io.tracks import read_track

    tr = read_track(video.with_name("news.csv"))
    assert tr.n_frames == math.ceil(tr.duration * FPS - 1e-9)
    for c in ("AU25", "AU45", "AU54", "AU61", "AU12"):
        assert c in tr.channels


@pytest.mark.render
def test_lips_move_while_speaking_and_rest_in_pauses(video, spoken):
    import av

    from mimika.face.heads import DEFAULT_HEAD, load_head
    from mimika.newsreader.pipeline import news_camera

    _, utt, _ = spoken
    head, _ = load_head(DEFAULT_HEAD)
    cam = news_camera(head, "front", 160 / 120)
    px = cam.project(np.array([head.anchors["mouth_corner_L"], head.anchors["mouth_corner_R"],
                               head.anchors["chin"]]), (160, 120))
    x0, x1 = int(px[:, 0].min()) - 2, int(px[:, 0].max()) + 3
    y0, y1 = int(px[:2, 1].min()) - 4, int(px[2, 1])
    with av.open(str(video)) as c:
        frames = np.stack([f.to_ndarray(format="rgb24")[y0:y1, x0:x1].astype(float)
                           for f in c.decode(video=0)])
    change = np.abs(np.diff(frames, axis=0)).mean(axis=(1, 2, 3))
    t = (np.arange(len(change)) + 0.5) / FPS
    speaking = np.zeros(len(t), bool)
    for w in utt.words:
        speaking |= (t >= w.start + 0.05) & (t <= w.end - 0.05)
    pause = np.zeros(len(t), bool)
    for p in utt.phonemes:
        if p.is_pause and p.duration > 0.5:
            pause |= (t >= p.start + 0.2) & (t <= p.end - 0.2)
    assert pause.any() and speaking.any()
    assert change[speaking].mean() > 2.0 * change[pause].mean()


def test_lips_close_on_bilabials_even_while_smiling(spoken):
    from mimika.speech import closure_ok

    art, utt, paras = spoken
    nt = news_track(art, utterance=utt, paragraph_starts=paras, fps=FPS)
    tr = nt.track
    assert tr["AU12"].max() >= 0.25  # the greeting smile
    mouth = nt.mouth
    for s, e, _ in mouth.meta["bilabial"]:
        i = round(0.5 * (s + e) * FPS)
        if i < tr.n_frames:
            assert closure_ok(tr.frame(i)), (s, tr.frame(i))


@pytest.mark.parametrize("off", [f for f in FEATURES if f not in ("skin", "hair")])
def test_each_switch_removes_exactly_its_behaviour(spoken, off):
    art, utt, paras = spoken
    full = news_track(art, utterance=utt, paragraph_starts=paras, fps=FPS, seed=3)
    less = news_track(art, utterance=utt, paragraph_starts=paras, fps=FPS, seed=3,
                      layers=set(FEATURES) - {off})
    assert off in full.layers and off not in less.layers
    for name, tr in less.layers.items():
        np.testing.assert_array_equal(tr.values, full.layers[name].values, err_msg=name)
    own = {"blink": ["AU45"], "gaze": ["AU61", "AU62", "AU63", "AU64"]}.get(off, [])
    for c in own:
        col = less.track[c] if c in less.track.channels else np.zeros(1)
        assert np.all(col == 0), c
    np.testing.assert_array_equal(less.track["AU25"], full.track["AU25"])  # speech untouched


def test_ablation_set_covers_seed_004_seven_features():
    # seed 004's seven: head motion, gaze, hair, blink, whole-body idle, skin, brows
    assert {"head", "gaze", "hair", "blink", "body", "skin", "brows"} <= set(ABLATIONS)
    assert set(ABLATIONS) <= set(FEATURES)


@pytest.mark.render
def test_skin_shader_changes_the_look_but_not_the_framing(builtin_rig):
    from mimika.render import Renderer
    from mimika.render.lighting import NEWS as NEWS_LIGHTING

    head = builtin_rig.head
    imgs = []
    for skin in (False, True):
        with Renderer(head, size=(160, 120), samples=0, skin_shader=skin,
                      lighting=NEWS_LIGHTING) as r:
            imgs.append(r.render().astype(float))
    plain, skin = imgs
    diff = np.abs(plain - skin).sum(2)
    assert diff.max() > 10  # the shader does something
    face = diff[30:90, 55:105]
    assert np.isfinite(skin).all() and skin[30:90, 55:105].mean() > 60  # not black
    assert (diff > 60).mean() < 0.05  # same silhouette and framing
    assert face.mean() < 40


def test_builtin_skin_uvs_have_their_seam_at_the_back(builtin_rig):
    from mimika.render.skin import seam_faces

    skin = builtin_rig.head["skin"]
    uv = skin.uvs
    assert uv.shape == (skin.n_vertices, 2) and uv.min() >= 0 and uv.max() <= 1
    f = np.concatenate([p.faces for p in skin.parts if p.material in ("skin", "lips")])
    seam = seam_faces(uv, f)
    centres = skin.vertices[f[seam]].mean(1)
    assert seam.sum() < 0.02 * len(f)
    assert np.all(centres[:, 2] < skin.vertices[:, 2].mean() + 1.0)  # behind the face


@pytest.mark.parametrize(("argv", "msg"), [
    (["news", "EMPTY", "-o", "OUT/news.mp4"], "is empty"),
    (["news", "ARTICLE", "--lang", "xx", "-o", "OUT/news.mp4"], "unknown language"),
    (["news", "ARTICLE", "-o", "/proc/mimika/news.mp4"], "cannot write"),
    (["news", "ARTICLE", "-o", "OUT/news.avi"], ".mp4"),
    (["news", "MISSING", "-o", "OUT/news.mp4"], "does not exist"),
    (["news", "ARTICLE"], "-o news.mp4"),
    (["news", "ARTICLE", "--size", "161x120", "-o", "OUT/news.mp4"], "even"),
])
def test_bad_input_gives_one_clear_error_and_writes_nothing(tmp_path, capsys, argv, msg):
    (tmp_path / "empty.txt").write_text("  \n", "utf-8")
    (tmp_path / "a.txt").write_text("Hello.", "utf-8")
    out = tmp_path / "out"
    subs = {"EMPTY": str(tmp_path / "empty.txt"), "ARTICLE": str(tmp_path / "a.txt"),
            "MISSING": str(tmp_path / "missing.txt")}
    argv = [subs.get(a, a.replace("OUT", str(out))) for a in argv]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mimika: error:") and msg in err[0]
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.render
def test_rendering_workers_write_the_same_video(spoken, builtin_rig, tmp_path):
    import av

    from mimika.newsreader import NewsTrack, render_news

    art, utt, paras = spoken
    once = NewsTrack(None, utt, {}, paras, None)  # one synthesis for both videos

    def frames(workers):
        out = tmp_path / f"w{workers}.mp4"
        render_news(art, out=out, size=(160, 120), seed=3, rig=builtin_rig, news=once,
                    workers=workers, subtitles=False)
        with av.open(str(out)) as c:
            return [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]

    a, b = frames(1), frames(2)
    assert len(a) == len(b) > 50
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_a_voice_that_fails_ends_the_rendering_processes_started_for_it(tmp_path,
                                                                        monkeypatch):
    """The rendering processes start while the voice speaks; when the voice fails they end
    with the render, leave no shared memory behind and no video."""
    import glob
    import multiprocessing as mp
    import os

    from mimika.errors import ParameterError
    from mimika.newsreader import pipeline

    started = []
    start = pipeline.start_pool
    monkeypatch.setattr(pipeline, "start_pool",
                        lambda *a, **k: started.append(start(*a, **k)) or started[-1])
    with pytest.raises(ParameterError, match="unknown voice"):
        pipeline.render_news(" ".join([TEXT] * 3), out=tmp_path / "x.mp4", head="builtin",
                             voice="no-such-voice")
    assert started
    deadline = time.monotonic() + 15  # a loaded machine takes a moment to reap a killed one
    while mp.active_children() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not mp.active_children()
    assert not glob.glob(f"/dev/shm/mimika-frames-{os.getpid()}-*")
    assert not list(tmp_path.iterdir())
