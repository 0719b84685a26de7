"""Visemes → mouth AU tracks: Cohen–Massaro coarticulation in AU space plus hard closure rules.

Model (parameters in ``speech/data/visemes.json``, documented in ``docs/speech.md``):

* every class segment *s* has a target ``T[s, k]`` for each mouth AU *k*;
* each AU belongs to a group (lips, round, spread, jaw); the segment's dominance for the
  group is ``α·exp(-(d/τ)²)`` where *d* is the distance in seconds outside the segment's core
  (the middle ``1 - 2·core`` of it) and τ is the anticipation time constant before the core,
  the carry-over constant after it (rounded classes use a longer anticipation for the round
  group, so rounding spreads over preceding consonants);
* the AU value is the dominance-weighted mean of the targets (plus a tiny rest target 0), so
  consonants with low jaw dominance let the jaw follow the vowels and nothing flaps;
* the result is box-filtered to each frame (sub-samples every 10 ms), then the closure rules
  are applied per frame: /p b m/ close the lips, /f v/ tuck the lower lip (see
  :func:`apply_closures`).
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Iterable, Sequence

import numpy as np

from mimika.errors import ParameterError
from mimika.limits import check_timeline
from mimika.speech.phonemes import Segment, segments, viseme_table
from mimika.speech.utterance import Utterance
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)


def mouth_aus() -> tuple[str, ...]:
    """The mouth AU channels speech drives, in output order."""
    return tuple(viseme_table()["mouth_aus"])


#: time constants after which a segment no longer moves a frame (its dominance is cut off)
REACH_TAUS = 4.0


@functools.cache
def _class_arrays() -> tuple[np.ndarray, ...]:
    """Per-class targets (C, K) and per-group dominance, anticipation, carry-over (C, G), for
    the viseme table's classes in order (read-only: built once)."""
    vt = viseme_table()
    classes = list(vt["classes"])
    aus, groups = vt["mouth_aus"], list(vt["groups"])
    tgt = np.array([[vt["classes"][c]["targets"].get(au, 0.0) for au in aus] for c in classes])
    dom, ant, car = (np.zeros((len(classes), len(groups))) for _ in range(3))
    for i, c in enumerate(classes):
        e = vt["classes"][c]
        for j, g in enumerate(groups):
            dom[i, j] = e["dominance"][g]
            ant[i, j] = e.get("anticipation_round", e["anticipation"]) if g == "round" \
                else e["anticipation"]
            car[i, j] = e["carryover"]
    for a in (tgt, dom, ant, car):
        a.setflags(write=False)
    return tgt, dom, ant, car


def max_reach() -> float:
    """Seconds beyond which no segment moves a frame: four time constants of the slowest
    class (as :func:`coarticulate` cuts them off)."""
    _, _, ant, car = _class_arrays()
    return REACH_TAUS * float(max(ant.max(), car.max()))


def _segment_params(segs: Sequence[Segment]):
    vt = viseme_table()
    co = vt["coarticulation"]
    classes = list(vt["classes"])
    idx = np.array([classes.index(s.cls) for s in segs])
    tgt, dom, ant, car = (a[idx] for a in _class_arrays())
    gain = np.array([co["stress_gain"][str(min(max(s.stress, 0), 2))] for s in segs])
    cols = [vt["mouth_aus"].index(a) for a in co["stress_aus"]]
    vowel = np.array([s.cls.startswith("vowel_") for s in segs])
    tgt[np.ix_(vowel, cols)] *= gain[vowel, None]
    st = np.array([s.start for s in segs])
    en = np.array([s.end for s in segs])
    core = co["core"] * (en - st)
    return np.clip(tgt, 0, 1), dom, 1.0 / ant, 1.0 / car, st + core, en - core


def coarticulate(segs: Sequence[Segment], times: np.ndarray) -> np.ndarray:
    """Blend class targets at ``times`` (seconds, shape (T,)) → AU values, shape (T, K).

    Dominance of segment *s* for AU group *g* at time *t*: ``α[s,g]·exp(-(d/τ[s,g])²)``, *d* the
    distance outside the segment core (τ = anticipation before it, carry-over after it); value
    ``Σ_s D·T / (Σ_s D + rest)``.
    """
    vt = viseme_table()
    aus = vt["mouth_aus"]
    cols = [[aus.index(a) for a in lst] for lst in vt["groups"].values()]
    out = np.zeros((len(times), len(aus)))
    if not segs or not len(times):
        return out
    tgt, dom, inv_ant, inv_car, lo, hi = _segment_params(segs)
    rest = vt["coarticulation"]["rest_dominance"]
    reach = REACH_TAUS / min(float(inv_ant.min()), float(inv_car.min()))
    starts = np.array([s.start for s in segs])
    ends = np.array([s.end for s in segs])
    block = 128
    for b0 in range(0, len(times), block):
        t = times[b0:b0 + block]
        sel = np.nonzero((ends > t[0] - reach) & (starts < t[-1] + reach))[0]
        if not len(sel):
            continue
        tt = t[:, None, None]
        before = np.maximum(lo[sel][None, :, None] - tt, 0.0)  # (T, S, 1)
        after = np.maximum(tt - hi[sel][None, :, None], 0.0)
        z = before * inv_ant[sel][None] + after * inv_car[sel][None]  # (T, S, G)
        d = dom[sel][None] * np.exp(-(z * z))
        for g, c in enumerate(cols):
            dg = d[:, :, g]
            out[b0:b0 + block, c] = (dg @ tgt[sel][:, c]) / (dg.sum(axis=1) + rest)[:, None]
    return out


def _apex_times(segs: Iterable[Segment], cls: str) -> list[float]:
    rule = viseme_table()["closure"][cls]
    return [s.start + rule["apex"] * s.duration for s in segs if s.cls == cls]


def bilabial_apex_times(utterance: Utterance) -> list[float]:
    """Times (s) at which the lips must be closed: the apex of every /p b m/ segment."""
    return _apex_times(segments(utterance), "bilabial")


def labiodental_apex_times(utterance: Utterance) -> list[float]:
    """Apex times (s) of every /f v/ segment (lower lip at the upper teeth)."""
    return _apex_times(segments(utterance), "labiodental")


def _hold_windows(segs: Sequence[Segment], cls: str) -> list[tuple[float, float, float]]:
    rule = viseme_table()["closure"][cls]
    h = rule["hold"]
    return [(s.start + h * s.duration, s.end - h * s.duration, s.start + rule["apex"] * s.duration)
            for s in segs if s.cls == cls]


def closure_weights(windows: Sequence[tuple[float, float, float]], *, fps: float, n_frames: int,
                    ramp: float, k0: int = 0) -> np.ndarray:
    """Per-frame weight in [0, 1] of a closure rule: 1 inside each hold window and on the two
    frames around each apex, a raised-cosine ramp of ``ramp`` s outside; shape (n_frames,)
    for frames ``k0`` … (frame k at k / fps s)."""
    t = (k0 + np.arange(n_frames)) / fps
    w = np.zeros(n_frames)
    for a, b, apex in windows:
        d = np.maximum(np.maximum(a - t, t - b), 0.0)
        w = np.maximum(w, np.where(d < ramp, 0.5 + 0.5 * np.cos(np.pi * d / max(ramp, 1e-9)), 0))
        f = apex * fps
        for i in (math.floor(f) - k0, math.ceil(f) - k0):
            if 0 <= i < n_frames:
                w[i] = 1.0
    return w


def _rule_target(values: np.ndarray, channels: Sequence[str], rule: dict) -> np.ndarray:
    """The frame values with ``rule`` enforced fully (zero / max / min / min_per_AU12)."""
    v = values.copy()
    col = {c: i for i, c in enumerate(channels)}
    au12 = v[:, col["AU12"]] if "AU12" in col else np.zeros(len(v))
    for au in rule["zero"]:
        if au in col:
            v[:, col[au]] = 0.0
    for au, m in rule["max"].items():
        if au in col:
            v[:, col[au]] = np.minimum(v[:, col[au]], m)
    for au, m in rule["min"].items():
        if au in col:
            extra = rule["min_per_AU12"].get(au, 0.0) * au12
            v[:, col[au]] = np.maximum(v[:, col[au]], np.minimum(m + extra, 1.0))
    return v


def apply_closures(values: np.ndarray, channels: Sequence[str], *, fps: float,
                   bilabial: Sequence[tuple[float, float, float]],
                   labiodental: Sequence[tuple[float, float, float]] = (),
                   k0: int = 0) -> np.ndarray:
    """Enforce the closure rules on frames ``k0`` … (shape (T, K)); returns a new array.

    Windows are ``(hold_start, hold_end, apex)`` in seconds. At weight 1 (hold window and the
    frames bracketing the apex) the rule holds exactly; around it the frames blend into it.
    Rules (``visemes.json`` → ``closure``): bilabial — AU09, AU10, AU16, AU25, AU26, AU27,
    AU28 = 0, AU22 ≤ 0.2, AU24 ≥ 0.4 + 0.3·AU12; labiodental — AU16 = AU24 = AU27 = 0,
    AU26 ≤ 0.08, AU28 ≥ 0.3, AU10 ≥ 0.15, AU25 ≥ 0.2.
    """
    need = {"AU24", "AU25", "AU26"}
    if not need <= set(channels):
        raise ParameterError(f"closure rules need channels {sorted(need)}; got {list(channels)}")
    rules = viseme_table()["closure"]
    v = np.asarray(values, dtype=np.float64).copy()
    for name, wins in (("labiodental", labiodental), ("bilabial", bilabial)):
        if not len(wins):
            continue
        rule = rules[name]
        w = closure_weights(wins, fps=fps, n_frames=len(v), ramp=rule["ramp"], k0=k0)[:, None]
        v = (1 - w) * v + w * _rule_target(v, channels, rule)
        exact = w[:, 0] >= 1.0
        v[exact] = _rule_target(v[exact], channels, rule)
    return v


def closure_ok(frame: dict[str, float], *, tol: float = 1e-6) -> bool:
    """Whether one frame (``{AU: value}``) satisfies the bilabial closure rule."""
    rule = viseme_table()["closure"]["bilabial"]
    if any(frame.get(au, 0.0) > tol for au in rule["zero"]):
        return False
    if any(frame.get(au, 0.0) > m + tol for au, m in rule["max"].items()):
        return False
    au12 = frame.get("AU12", 0.0)
    for au, m in rule["min"].items():
        need = min(m + rule["min_per_AU12"].get(au, 0.0) * au12, 1.0)
        if frame.get(au, 0.0) < need - tol:
            return False
    return True


def pauses(utterance: Utterance, *, min_duration: float = 0.0) -> list[tuple[float, float]]:
    """``(start, end)`` of every pause phone at least ``min_duration`` s long."""
    return [(p.start, p.end) for p in utterance.phonemes
            if p.is_pause and p.duration >= min_duration]


def mouth_track(utterance: Utterance, *, fps: float = 25.0, strength: float = 1.0) -> AUTrack:
    """Mouth AU track of an utterance (TTS or aligned), frames at ``k / fps`` s.

    Parameters
    ----------
    fps : float
        Frame rate (> 0); any rate works (25–60 typical).
    strength : float
        Articulation gain in [0, 2] applied to the blended targets before the closure rules
        (1 = as tuned; < 1 mumbles, > 1 over-articulates).

    Returns
    -------
    AUTrack
        ``values`` shape (ceil(duration·fps), 13) in [0, 1] over :func:`mouth_aus`; ``meta``
        holds ``bilabial`` / ``labiodental`` closure windows and ``pauses`` (seconds) so that
        :func:`mimika.speech.combine` can re-apply the closures after mixing in emotion.
    """
    fps = valid_fps(fps)
    if not 0.0 <= strength <= 2.0:
        raise ParameterError(f"strength={strength} must be in [0, 2]")
    check_timeline(utterance.duration, fps, "the speech")  # before allocating the frames
    segs = segments(utterance)
    n = max(1, math.ceil(utterance.duration * fps - 1e-9))
    vals = mouth_frames(segs, fps=fps, k0=0, n=n, strength=strength)
    meta = {"source": "mimika.speech", "lang": utterance.lang,
            "bilabial": _hold_windows(segs, "bilabial"),
            "labiodental": _hold_windows(segs, "labiodental"), "pauses": pauses(utterance)}
    return AUTrack(vals, mouth_aus(), fps, meta)


def mouth_frames(segs: Sequence[Segment], *, fps: float, k0: int, n: int,
                 strength: float = 1.0) -> np.ndarray:
    """Mouth AU values (:func:`mouth_aus`) of frames ``k0 … k0 + n - 1`` (frame k at k / fps
    s) of class segments ``segs``, as :func:`mouth_track` computes them; float32 (n, 13).

    A frame depends on the segments within the coarticulation reach around it only, so a
    stream can compute its frames from the segments heard so far."""
    sub = max(1, math.ceil(viseme_table()["coarticulation"]["subsample_hz"] / fps))
    offs = (np.arange(sub) - (sub - 1) / 2) / (sub * fps)
    t = ((k0 + np.arange(n))[:, None] / fps + offs[None, :]).ravel()
    vals = coarticulate(segs, np.clip(t, 0, None)).reshape(n, sub, -1).mean(axis=1)
    vals = np.clip(vals * strength, 0.0, 1.0)
    vals = apply_closures(vals, mouth_aus(), fps=fps, bilabial=_hold_windows(segs, "bilabial"),
                          labiodental=_hold_windows(segs, "labiodental"), k0=k0)
    return np.clip(vals, 0, 1).astype(np.float32)
