"""The newsreader pipeline: article → speech → behaviour → AU track → frames → MP4 + SRT."""

from __future__ import annotations

import contextlib
import logging
import os
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mimika import limits
from mimika.errors import DataError, ParameterError
from mimika.newsreader.article import Article, parse_article, speak_article
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)

#: every feature of the newsreader; "skin" is the skin shader, "hair" draws the hair, the rest
#: are behaviour layers ("body": whole-body idle, for heads with a body)
FEATURES = ("head", "gaze", "blink", "idle", "body", "brows", "smile", "knowledge", "skin",
            "hair")
#: not behaviour layers: how the head is drawn
_DRAWING = ("skin", "hair")
#: the seed's ablation set (seed 004's seven: head motion, gaze, hair, blink, whole-body idle,
#: skin, brows; plus idle sway and smile): each switched off once, plus the all-features video
ABLATIONS = ("head", "gaze", "hair", "blink", "body", "skin", "brows", "idle", "smile")
#: CLI / file names of the features
FLAG_NAMES = {"head": "head-motion", "gaze": "gaze", "blink": "blink", "idle": "idle",
              "body": "body-idle", "brows": "brows", "smile": "smile",
              "knowledge": "knowledge", "skin": "skin-shader", "hair": "hair"}


def _shots() -> dict[str, Any]:
    import json
    from importlib import resources

    text = resources.files("mimika.newsreader").joinpath("data/shots.json").read_text("utf-8")
    return {k: v for k, v in json.loads(text).items() if not k.startswith("_")}


#: the camera shots (``data/shots.json``): heads with a body are framed by the head's share
#: of the image height and the eyes' line; a bare head by the face's fill, centred
SHOTS: dict[str, dict[str, float]] = _shots()["shots"]
SHOT_NAMES = tuple(SHOTS)
#: the shot and video size of ``mimika news`` by default: a TV medium close-up in HD
DEFAULT_SHOT: str = _shots()["default"]
DEFAULT_SIZE: tuple[int, int] = tuple(_shots()["size"])  # type: ignore[assignment]
CHUNK = 25  #: frames per task of a rendering process
#: the default shot in the studio's terms (its viewer frames by the face, hairline to chin,
#: which is about 0.83 of the head, crown to chin)
FILL = SHOTS[DEFAULT_SHOT]["fill"]
BUST_FILL = round(0.83 * SHOTS[DEFAULT_SHOT]["head"], 3)
EYE_LINE = SHOTS[DEFAULT_SHOT]["eye_line"]

Progress = Callable[[int, int], None]


def check_layers(layers: Iterable[str] | None) -> frozenset[str]:
    """The enabled features (default: all of :data:`FEATURES`); unknown names raise."""
    if layers is None:
        return frozenset(FEATURES)
    out = frozenset(layers)
    bad = sorted(out - set(FEATURES))
    if bad:
        raise ParameterError(f"unknown newsreader feature(s) {', '.join(bad)}; "
                             f"features: {', '.join(FEATURES)}")
    return out


@dataclass
class NewsTrack:
    """The animation of an article: the final AU ``track``, the speech ``utterance``, the
    behaviour ``layers`` (name → AUTrack) and the ``paragraph_starts`` (s)."""

    track: AUTrack
    utterance: Any
    layers: dict[str, AUTrack]
    paragraph_starts: list[float]
    mouth: AUTrack


@dataclass
class NewsResult:
    """What :func:`render_news` wrote, with per-stage wall times (s) in ``timings``."""

    video: Path
    subtitles: Path | None
    duration: float
    n_frames: int
    fps: float
    timings: dict[str, float] = field(default_factory=dict)
    aus: Path | None = None
    track: AUTrack | None = None


def _retime_script(article: Article, utt: Any, *, fps: float, n_frames: int) -> AUTrack | None:
    """The script's own events, moved from text timing to the speech's word times."""
    from dataclasses import replace

    from mimika.timeline.player import sample
    from mimika.timeline.speech import time_speech

    tl = article.script
    if tl is None or not tl.channels:
        return None
    timing = time_speech(tl.speech, rate=tl.rate)
    positions = utt.meta.get("script_positions")
    if positions is not None and len(positions) == len(timing.times):
        src, dst = np.array(timing.times), np.array(positions, float)
    else:  # no positions (an utterance made elsewhere): stretch text time linearly
        end = tl.speech_end() or tl.end
        src = np.array([0.0, max(end, 1e-3)])
        dst = np.array([utt.words[0].start if utt.words else 0.0,
                        utt.words[-1].end if utt.words else utt.duration])
    order = np.argsort(src, kind="stable")
    src, dst = src[order], dst[order]

    def f(x: float) -> float:
        return float(np.interp(x, src, dst, left=dst[0] + x - src[0],
                               right=dst[-1] + x - src[-1]))

    chans = []
    for ch in tl.channels:
        evs = []
        for e in ch.events:
            s, t = max(f(e.start), 0.0), max(f(e.end), 0.0)
            if t - s < 0.04:
                t = s + max(e.duration, 0.04)
            evs.append(replace(e, start=s, duration=t - s, onset=None if e.onset is None else
                               min(e.onset, 0.5 * (t - s)), offset=None if e.offset is None
                               else min(e.offset, 0.5 * (t - s)), at=None))
        chans.append(replace(ch, events=tuple(evs)))
    tr = sample(tl.with_channels(chans), fps=fps, duration=n_frames / fps)
    v = tr.values[:n_frames]
    return AUTrack(v, tr.channels, fps, {"layer": "script"})


def news_track(article: Article | str, *, lang: str = "en", fps: float = 25.0,
               layers: Iterable[str] | None = None, voice: str | None = None,
               rate: int = 165, pitch: int = 50, seed: int | None = None,
               params: dict[str, Any] | None = None, supported: Iterable[str] | None = None,
               utterance: Any = None, paragraph_starts: list[float] | None = None,
               mood: str | None = None, engine: str | None = None) -> NewsTrack:
    """Speech, behaviour layers and the final blended AU track of an article.

    ``utterance`` (with ``paragraph_starts``) reuses an earlier synthesis or an alignment of
    a recording. ``supported`` restricts the final channels to what a rig models. ``mood``
    (default: the script's, else neutral) changes how often and how strongly the layers act.
    The final track has ``ceil(duration · fps)`` frames, frame i at i / fps s.
    """
    from mimika.behaviour import merge_layers
    from mimika.behaviour.mood import mood_params
    from mimika.behaviour.speaking import speaking_behaviour
    from mimika.facs.blender import blend_track
    from mimika.speech import combine, mouth_track

    fps = valid_fps(fps)
    enabled = check_layers(layers)
    art = parse_article(article) if isinstance(article, str) else article
    if utterance is None:
        utterance, paragraph_starts = speak_article(art, lang=lang, voice=voice, rate=rate,
                                                    pitch=pitch, engine=engine)
    paras = list(paragraph_starts or [])
    if mood is None and art.script is not None:
        mood = art.script.mood
    mouth = mouth_track(utterance, fps=fps)
    n = mouth.n_frames
    params = mood_params(mood, params)
    _, beh = speaking_behaviour(utterance, fps=fps, seed=seed, params=params,
                                layers=[x for x in FEATURES if x in enabled and x not in _DRAWING],
                                paragraph_starts=paras, n_frames=n)
    parts = dict(beh)
    script = _retime_script(art, utterance, fps=fps, n_frames=n)
    if script is not None and script.channels:
        parts["script"] = script
    emotion = merge_layers(parts, params=params, n_frames=n, fps=fps)
    track = blend_track(combine(mouth, emotion)) if emotion.channels else blend_track(mouth)
    if supported is not None:
        sup = set(supported)
        dropped = [c for c in track.channels if c not in sup]
        if dropped:
            log.info("the head does not model %s; left out", ", ".join(dropped))
        track = track.with_channels([c for c in track.channels if c in sup])
    track = AUTrack(track.values[:n], track.channels, fps,
                    {"source": "mimika.newsreader", "lang": utterance.lang,
                     "layers": sorted(enabled), "mood": mood or "neutral"})
    return NewsTrack(track, utterance, beh, paras, mouth)


def _check_output(out: Path) -> None:
    if out.suffix.lower() != ".mp4":
        raise ParameterError(f"output {str(out)!r} must be an .mp4 file")
    parent = out.parent if str(out.parent) else Path(".")
    probe_dir = parent
    while not probe_dir.exists():
        probe_dir = probe_dir.parent
    if not probe_dir.is_dir() or not os.access(probe_dir, os.W_OK | os.X_OK):
        raise DataError(f"cannot write {str(out)!r}: {str(probe_dir)!r} is not a writable "
                        "folder; choose another output path with -o")
    if out.is_dir():
        raise DataError(f"cannot write {str(out)!r}: it is a folder")
    try:  # fail now, not after minutes of rendering
        parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as e:
        raise DataError(f"cannot write {str(out)!r}: {e.strerror or e}; choose another "
                        "output path with -o") from None


def check_shot(shot: str) -> dict[str, float]:
    """The settings of the named shot, or a ParameterError naming the shots."""
    if shot not in SHOTS:
        raise ParameterError(f"unknown shot {shot!r}; shots: {', '.join(SHOT_NAMES)}")
    return SHOTS[shot]


def news_camera(head: Any, view: str, aspect: float, shot: str = DEFAULT_SHOT) -> Any:
    """The newsreader's camera for ``shot`` (:data:`SHOTS`): for heads with a body the head
    (crown to chin) takes its share of the image height with the eyes on its eye line (the
    default: a TV medium close-up, eyes on the upper third line, head a third of the height,
    shoulders in); a bare head is a centred close-up of the face."""
    from mimika.render.camera import frame_head

    s = check_shot(shot)
    if any(o.category == "body" for o in head.objects) or head.meta.get("body"):
        return frame_head(head, view, aspect=aspect, head_share=s["head"],
                          eye_line=s["eye_line"])
    return frame_head(head, view, aspect=aspect, fill=s["fill"])


def _frame_settings(rig: Any, *, size: tuple[int, int], view: str, skin_shader: bool,
                    hair: bool, light: Any, shot: str) -> dict[str, Any]:
    """The renderer settings of a news video (:func:`render_frames`), as
    :func:`~mimika.render.parallel.render_track` and its pool take them."""
    from mimika.face.heads.roles import objects_of_role
    from mimika.render.lighting import parse_light
    from mimika.render.skin import SkinParams

    # video: the blurred skin irradiance is refreshed every third frame (see SkinParams)
    return {"camera": news_camera(rig.head, view, size[0] / size[1], shot), "size": size,
            "skin": SkinParams(refresh=3) if skin_shader else False,
            "lighting": parse_light(light, "news"),
            "hidden": () if hair else objects_of_role(rig.head, "hair")}


def start_pool(rig: Any, *, workers: int, size: tuple[int, int], view: str = "front",
               samples: int = 0, skin_shader: bool = True, hair: bool = True,
               light: Any = None, shot: str = DEFAULT_SHOT) -> Any:
    """Rendering processes for :func:`render_frames` with the same settings, started now so
    that they set up while the caller is busy (e.g. with speech)."""
    from mimika.render.parallel import RenderPool

    return RenderPool(rig, workers=workers, samples=samples,
                      **_frame_settings(rig, size=size, view=view, skin_shader=skin_shader,
                                        hair=hair, light=light, shot=shot))


def render_frames(rig: Any, track: AUTrack, *, size: tuple[int, int], view: str = "front",
                  samples: int = 0, skin_shader: bool = True, hair: bool = True,
                  chunk: int = CHUNK, workers: int | None = 1,
                  timings: dict[str, float] | None = None, light: Any = None,
                  shot: str = DEFAULT_SHOT, pool: Any = None):
    """Yield rendered frames, (H, W, 3) uint8 each, of ``track`` on ``rig``'s head.

    Frames are deformed and drawn in chunks of ``chunk`` by ``workers`` processes
    (:mod:`mimika.render.parallel`; None: one per core for long tracks), or by ``pool``
    (:func:`start_pool` with the same settings). The images do not depend on ``workers``.
    ``hair=False`` leaves the hair out. ``light``: a ``--light`` spec or
    :class:`~mimika.render.lighting.Lighting` (default: the ``news`` set); ``shot``: one of
    :data:`SHOTS`.
    """
    from mimika.render.parallel import default_workers, render_track

    tm = timings if timings is not None else {}
    if pool is not None:
        workers = pool.workers
    elif workers is None:
        workers = default_workers(track.n_frames, chunk)
    frames = render_track(rig, track.values, track.channels, samples=samples, chunk=chunk,
                          workers=workers, pool=pool,
                          **_frame_settings(rig, size=size, view=view,
                                            skin_shader=skin_shader, hair=hair, light=light,
                                            shot=shot))
    tm["workers"] = workers
    while True:  # the time spent waiting for frames
        t0 = time.perf_counter()
        img = next(frames, None)
        tm["render"] = tm.get("render", 0.0) + time.perf_counter() - t0
        if img is None:
            return
        yield img


def _in_background(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Callable[[], Any]:
    """Start ``fn`` on a daemon thread (a failed run elsewhere does not wait for it); the
    returned function waits for it and returns its result or raises its error."""
    import threading

    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["value"] = fn(*args, **kwargs)
        except BaseException as e:  # handed to the caller
            box["error"] = e

    th = threading.Thread(target=run, name="mimika-background", daemon=True)
    th.start()

    def wait() -> Any:
        th.join()
        if "error" in box:
            raise box["error"]
        return box["value"]

    return wait


def render_news(text: str | Article, *, out: str | os.PathLike, lang: str = "en",
                head: str | None = None, layers: Iterable[str] | None = None,
                progress: Progress | None = None, fps: float = 25.0,
                size: tuple[int, int] = DEFAULT_SIZE, view: str = "front",
                voice: str | None = None, rate: int = 165, samples: int = 0,
                seed: int | None = None, subtitles: bool = True,
                aus: str | os.PathLike | None = None, crf: int = 23,
                preset: str = "veryfast", rig: Any = None, news: NewsTrack | None = None,
                workers: int | None = None, audio: str | os.PathLike | None = None,
                mood: str | None = None, light: Any = None, engine: str | None = None,
                shot: str = DEFAULT_SHOT, title: str | None = None) -> NewsResult:
    """Read ``text`` (plain article or ``<speak>`` script) as a newsreader into an MP4.

    Writes ``out`` (H.264 yuv420p + AAC, ``fps`` frames/s, frame i showing time i / fps, video
    duration = audio duration within one frame), ``out`` with ``.srt`` (one cue per sentence)
    unless ``subtitles=False``, and the final AU track as CSV to ``aus`` if given. All files
    are written atomically. ``layers``: enabled features of :data:`FEATURES` (default all).
    ``rig``/``news`` reuse a loaded head / a computed :class:`NewsTrack` (ablations).
    ``workers``: rendering processes (None: one per core for videos over 6 s; 1: none). With
    more than one, call this from a script under ``if __name__ == "__main__":``.
    ``audio``: a recording of the text (WAV, MP3 … any voice) — the text is aligned to it and
    the video carries it unchanged, so the video lasts exactly as long as the recording.
    ``mood``: see :func:`news_track`. ``light``: a ``--light`` spec (default ``news``).
    ``engine``/``voice``: who speaks (:func:`mimika.speech.tts.synthesize`). ``shot``: the
    framing (:data:`SHOTS`); ``title``: a lower-third name strap ("Name — Programme") shown
    over the first seconds (:class:`mimika.render.video.TitleStrap`).
    """
    from mimika.render.video import VideoWriter

    out = Path(out)
    _check_output(out)
    w, h = (int(x) for x in size)
    if w % 2 or h % 2:
        raise ParameterError(f"size={w}x{h}: width and height must be even for H.264 video")
    enabled = check_layers(layers)
    fps = valid_fps(fps)
    check_shot(shot)
    from mimika.render.video import TitleStrap

    strap = TitleStrap(title, (w, h)) if title is not None else None
    from mimika.render.lighting import parse_light

    light = parse_light(light, "news")
    if news is None:  # refuse an article too long to say before loading anything
        limits.check_speech(text if isinstance(text, str) else text.text, rate, "the article")
    tm: dict[str, float] = {}
    t_all = time.perf_counter()
    art = None
    speech = None
    if news is None:
        art = parse_article(text, source="<article>") if isinstance(text, str) else text
        if audio is None:  # speak while the head loads (the voices release the GIL)
            speech = _in_background(speak_article, art, lang=lang, voice=voice, rate=rate,
                                    engine=engine)
    if rig is None:
        from mimika.face.heads import DEFAULT_HEAD, load_head

        t0 = time.perf_counter()
        _, rig = load_head(head or DEFAULT_HEAD)
        tm["load_head"] = time.perf_counter() - t0
    pool = None
    if workers is None and audio is None and art is not None:
        # the rendering processes set up while the voice still speaks (from the text's
        # length: the frames are not known yet)
        from mimika.render.parallel import default_workers

        est = round(limits.speech_seconds(art.text, rate) * fps)
        if default_workers(est, CHUNK) > 1:
            pool = start_pool(rig, workers=default_workers(est, CHUNK), size=(w, h),
                              view=view, samples=samples, skin_shader="skin" in enabled,
                              hair="hair" in enabled, light=light, shot=shot)
    try:
        t0 = time.perf_counter()
        if art is not None:
            t1 = time.perf_counter()
            if audio is not None:
                from mimika.newsreader.article import align_article
                from mimika.speech.audio import read_media

                rec, sr = read_media(audio)
                utt, paras = align_article(art, rec, sr=sr, lang=lang)
                tm["align"] = time.perf_counter() - t1
            else:
                utt, paras = speech()
                tm["tts_wait"] = time.perf_counter() - t1
            t1 = time.perf_counter()
            news = news_track(art, lang=lang, fps=fps, layers=enabled, seed=seed,
                              supported=rig.supported, utterance=utt, paragraph_starts=paras,
                              mood=mood)
            tm["tracks"] = time.perf_counter() - t1
        else:
            news = news_track(text if isinstance(text, Article) else parse_article(text),
                              lang=lang, fps=fps, layers=enabled, seed=seed,
                              supported=rig.supported, utterance=news.utterance,
                              paragraph_starts=news.paragraph_starts, mood=mood)
            tm["tracks"] = time.perf_counter() - t0
        track, utt = news.track, news.utterance
        n = track.n_frames
        if utt.meta.get("source") == "alignment":  # a recording: exactly as it was
            sound = utt.audio
        else:  # pad the audio to the video's length so both streams end together
            sound = np.zeros(round(n / fps * utt.sr), np.float32)
            sound[: min(len(sound), len(utt.audio))] = utt.audio[: len(sound)]
        frames = render_frames(rig, track, size=(w, h), view=view, samples=samples,
                               skin_shader="skin" in enabled, hair="hair" in enabled,
                               workers=workers, timings=tm, light=light, shot=shot, pool=pool)
        # closing: an interrupted render stops its worker processes at once
        with VideoWriter(out, fps=fps, size=(w, h), audio=sound, sr=utt.sr, crf=crf,
                         preset=preset, overlay=strap) as vw, contextlib.closing(frames):
            for i, img in enumerate(frames):
                vw.write(img)
                if progress is not None:
                    progress(i + 1, n)
            t0 = time.perf_counter()
        tm["encode_wait"] = time.perf_counter() - t0
    except BaseException:  # the early rendering processes end with the render
        if pool is not None:
            pool.stop()
        raise
    tm["encode"] = vw.encode_seconds
    srt = None
    if subtitles:
        from mimika.newsreader.subtitles import sentence_cues, write_srt

        srt = out.with_suffix(".srt")
        write_srt(srt, sentence_cues(utt))
    aus_path = None
    if aus is not None:
        from mimika.io.tracks import write_track

        aus_path = Path(aus)
        write_track(track, aus_path, format="au")
    tm["total"] = time.perf_counter() - t_all
    log.info("news video %s: %d frames, %.2f s audio, %.1f s wall", out, n, utt.duration,
             tm["total"])
    return NewsResult(out, srt, utt.duration, n, fps, tm, aus_path, track)


def render_ablations(text: str | Article, *, out_dir: str | os.PathLike, stem: str = "news",
                     progress: Callable[[str, int, int], None] | None = None,
                     **kwargs: Any) -> list[NewsResult]:
    """The seed 004 ablation set: all features, then each of :data:`ABLATIONS` switched off,
    as ``{stem}_all.mp4`` and ``{stem}_no-{feature}.mp4`` in ``out_dir`` (one synthesis)."""
    from mimika.face.heads import DEFAULT_HEAD, load_head

    d = Path(out_dir)
    kwargs.pop("layers", None)
    _, rig = load_head(kwargs.pop("head", None) or DEFAULT_HEAD)
    art = parse_article(text) if isinstance(text, str) else text
    lang = kwargs.get("lang", "en")
    utt, paras = speak_article(art, lang=lang, voice=kwargs.get("voice"),
                               rate=kwargs.get("rate", 165), engine=kwargs.get("engine"))
    base = NewsTrack(None, utt, {}, paras, None)  # type: ignore[arg-type]
    results = []
    variants = [("all", frozenset(FEATURES))] + [
        (f"no-{FLAG_NAMES[a]}", frozenset(FEATURES) - {a}) for a in ABLATIONS]
    for name, feats in variants:
        cb = None
        if progress is not None:
            def cb(done: int, total: int, name: str = name) -> None:
                progress(name, done, total)
        results.append(render_news(art, out=d / f"{stem}_{name}.mp4", layers=feats, rig=rig,
                                   news=base, progress=cb, **kwargs))
    return results
