"""The evaluation protocol for transition generators: held-out takes and a held-out person.

* **Segmentation** is fitted once on every take of the pool (unsupervised, canonical order —
  the same transitions whatever the file order); folds decide only which takes' transitions
  train a model. Models never see a test take's transitions.
* **Folds**: leave-one-take-out over every take (:func:`leave_one_take_out`; learned models
  that early-stop use the next take as their inner validation take) and leave-one-person-out
  (:func:`leave_one_person_out`: train on one person, test on another, scored on the channels
  both carry — :func:`mask_take` zeroes the rest).
* **Per transition** every method's squared error, L2, jump %, seed 000's conspicuousness and
  the timing of each AU group (onset latency, peak velocity) are kept, next to the transition's
  length and size (largest AU change), so any subset — a take, a size bin — can be summarised.
* **Intervals**: percentile bootstrap over transitions, resampled within each test take
  (:func:`bootstrap`); comparisons are paired (one resample for both methods).
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from mimika.learn.data import MODEL_CHANNELS, Split, Take, Transition, fixed_windows
from mimika.learn.evaluate import Generator, baseline_generator, model_generator
from mimika.learn.metrics import conspicuous, jump_percent, l2
from mimika.learn.transition_timing import GROUPS

log = logging.getLogger(__name__)

__all__ = ["SIZE_BINS", "Baseline", "Fold", "Learned", "Results", "bootstrap",
           "concat", "leave_one_person_out", "leave_one_take_out", "mask_take",
           "merge_methods",
           "run_protocol",
           "score_items", "summarise", "validation_record"]

#: transition sizes (largest |target − start| over AUs): name, lower, upper bound
SIZE_BINS = (("small", 0.0, 0.2), ("medium", 0.2, 0.5), ("large", 0.5, math.inf))
#: a group's timing is measured when its largest AU change is at least this
MIN_GROUP_CHANGE = 0.1


@dataclass(frozen=True)
class Fold:
    """Takes that train, test and validate (the inner validation take a learned model may
    early-stop on; :class:`Learned` with ``inner_val=False`` trains on it too); ``channels``
    are the channels scored."""

    name: str
    train: tuple[str, ...]
    test: tuple[str, ...]
    val: tuple[str, ...] = ()
    channels: tuple[str, ...] = MODEL_CHANNELS


def leave_one_take_out(names: Sequence[str]) -> list[Fold]:
    """One fold per take (sorted names): that take tests, the next one (cyclically) is the
    inner validation take, the rest train."""
    ns = sorted(names)
    if len(ns) < 3:
        raise ValueError(f"leave-one-take-out needs ≥ 3 takes, got {len(ns)}")
    out = []
    for i, t in enumerate(ns):
        v = ns[(i + 1) % len(ns)]
        out.append(Fold(f"take {t}", tuple(n for n in ns if n not in (t, v)), (t,), (v,)))
    return out


def leave_one_person_out(train: Sequence[str], test: Sequence[str],
                         channels: Sequence[str], *, name: str = "person") -> Fold:
    """Train on ``train`` takes (the last sorted one is the inner validation take), test on
    ``test`` (another person), scored on ``channels``."""
    tr = sorted(train)
    return Fold(name, tuple(tr[:-1]), tuple(sorted(test)), (tr[-1],), tuple(channels))


def mask_take(take: Take, channels: Sequence[str]) -> Take:
    """``take`` with every channel outside ``channels`` set to 0."""
    keep = np.isin(take.channels, list(channels))
    return replace(take, variants={f: v * keep for f, v in take.variants.items()})


class Method(Protocol):
    name: str
    batched: bool

    def fit(self, data: Any) -> Generator: ...


@dataclass
class Baseline:
    """An interpolation baseline (:mod:`mimika.learn.baselines`); nothing to fit."""

    name: str
    batched: bool = False

    def fit(self, data: Any) -> Generator:
        return baseline_generator(self.name)


@dataclass
class Learned:
    """A transition model trained per fold with ``config`` (:func:`mimika.learn.train.train`);
    ``inner_val`` keeps the fold's validation take out of training (for early stopping)."""

    name: str
    config: Any
    inner_val: bool = True
    batched: bool = True
    checkpoints: dict[str, dict] = field(default_factory=dict)
    progress: Callable[[int, int, dict], None] | None = None

    def fit(self, data: Any) -> Generator:
        from mimika.learn.train import load_state, train

        if not self.inner_val:
            s = data.split
            data = replace(data, split=Split(s.train + s.val, (), s.test))
        ck = train(data, self.config, progress=self.progress)
        self.checkpoints[str(data.split.test)] = ck
        return model_generator(load_state(ck))


def _group_index(channels: Sequence[str]) -> np.ndarray:
    names = list(GROUPS)
    return np.array([next((g for g, n in enumerate(names) if c in GROUPS[n]), -1)
                     for c in channels])


def group_timing(start: np.ndarray, frames: np.ndarray, target: np.ndarray,
                 groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per AU group (G,): onset latency (frames until the group's progress reaches 10 %) and
    peak velocity (largest progress step × the group's largest change, AU units per frame);
    NaN for groups that change less than :data:`MIN_GROUP_CHANGE`."""
    G = len(GROUPS)
    onset, peak = np.full(G, np.nan), np.full(G, np.nan)
    seq = np.concatenate([start[None], frames])
    d = target - start
    for g in range(G):
        m = groups == g
        size = np.abs(d[m]).max() if m.any() else 0.0
        if size < MIN_GROUP_CHANGE:
            continue
        p = (seq[:, m] - start[m]) @ d[m] / float(d[m] @ d[m])
        onset[g] = int(np.argmax(p >= 0.1)) if np.any(p >= 0.1) else len(frames)
        peak[g] = float(np.max(np.diff(p))) * size
    return onset, peak


@dataclass
class Results:
    """Per-transition records of every method (rows: transitions of every fold's test takes).

    ``se`` (M, N): summed squared error over frames and scored channels; ``count`` (N,):
    frames × scored channels; ``l2``/``jump``/``consp`` (M, N); ``onset``/``peak`` (M + 1, N,
    G) — row 0 is the ground truth; ``windows[L]``: (takes (W,), l2 (M, W)) for fixed windows
    of L generated frames.
    """

    methods: list[str]
    baselines: list[str]
    fold: np.ndarray
    take: np.ndarray
    length: np.ndarray
    size: np.ndarray
    count: np.ndarray
    se: np.ndarray
    l2: np.ndarray
    jump: np.ndarray
    gt_jump: np.ndarray
    consp: np.ndarray
    onset: np.ndarray
    peak: np.ndarray
    windows: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    def subset(self, mask: np.ndarray) -> Results:
        """The transitions where ``mask`` (N,) holds (without the fixed windows)."""
        m = np.asarray(mask, bool)
        return replace(self, fold=self.fold[m], take=self.take[m], length=self.length[m],
                       size=self.size[m], count=self.count[m], se=self.se[:, m],
                       l2=self.l2[:, m], jump=self.jump[:, m], gt_jump=self.gt_jump[m],
                       consp=self.consp[:, m], onset=self.onset[:, m], peak=self.peak[:, m],
                       windows={})

    def of_take(self, name: str) -> Results:
        """One test take's transitions and fixed windows."""
        win = {L: (t[t == name], v[:, t == name]) for L, (t, v) in self.windows.items()}
        return replace(self.subset(self.take == name), windows=win)

    def size_bin(self, name: str) -> Results:
        """The transitions of one of :data:`SIZE_BINS` (by name)."""
        _, lo, hi = next(b for b in SIZE_BINS if b[0] == name)
        return self.subset((self.size >= lo) & (self.size < hi))


def _score(gen: Generator, batched: bool, items: Sequence[Transition]) -> list[np.ndarray]:
    from mimika.learn.evaluate import _run

    return _run(gen, items, gen if batched else None)


_FIELDS = ("fold", "take", "length", "size", "count", "se", "l2", "jump", "gt_jump", "consp",
           "onset", "peak")


def _records(rec: dict[str, list], fold: str, items: Sequence[Transition],
             outs: Sequence[list[np.ndarray]], channels: Sequence[str]) -> None:
    """Append one row per transition of ``items`` (``outs``: each method's generated frames)."""
    cols = np.isin(MODEL_CHANNELS, list(channels))
    groups = _group_index(np.array(MODEL_CHANNELS)[cols])
    for i, t in enumerate(items):
        w, gt = t.window[:, cols], t.frames[:, cols]
        a, b = t.start_frame[cols], t.target[cols]
        gen = [o[i][:, cols] for o in outs]
        tim = [group_timing(a, f, b, groups) for f in (gt, *gen)]
        for k, v in (("fold", fold), ("take", t.take), ("length", t.length),
                     ("size", float(np.abs(b - a).max())), ("count", gt.size),
                     ("gt_jump", jump_percent(w, gt)),
                     ("se", [float(np.sum((g - gt) ** 2)) for g in gen]),
                     ("l2", [l2(g, gt) for g in gen]),
                     ("jump", [jump_percent(w, g) for g in gen]),
                     ("consp", [conspicuous(w, g, gt).any for g in gen]),
                     ("onset", [x[0] for x in tim]), ("peak", [x[1] for x in tim])):
            rec[k].append(v)


def _results(names: list[str], baselines: list[str], rec: dict[str, list],
             windows: dict[int, tuple[np.ndarray, np.ndarray]] | None = None) -> Results:
    G = len(GROUPS)
    arr = {k: np.array(v) for k, v in rec.items()}
    M = len(names)
    if not len(arr["take"]):  # no transitions: empty arrays of the right shapes
        arr.update({k: np.zeros((0, M)) for k in ("se", "l2", "jump", "consp")})
        arr.update({k: np.zeros((0, M + 1, G)) for k in ("onset", "peak")})
    return Results(
        names, baselines, arr["fold"], arr["take"], arr["length"], arr["size"], arr["count"],
        arr["se"].T, arr["l2"].T, arr["jump"].T, arr["gt_jump"], arr["consp"].T.astype(bool),
        np.transpose(arr["onset"], (1, 0, 2)), np.transpose(arr["peak"], (1, 0, 2)),
        windows or {})


def score_items(items: Sequence[Transition], methods: dict[str, tuple[Generator, bool]], *,
                baselines: Sequence[str] = (), channels: Sequence[str] = MODEL_CHANNELS,
                fold: str = "") -> Results:
    """Records of already-fitted generators (name → (generator, batched)) on ``items``."""
    rec: dict[str, list] = {k: [] for k in _FIELDS}
    outs = [_score(g, b, items) for g, b in methods.values()]
    _records(rec, fold, items, outs, channels)
    return _results(list(methods), list(baselines), rec)


def run_protocol(takes: dict[str, Take], folds: Sequence[Fold], methods: Sequence[Method], *,
                 l2_lengths: Sequence[int] = (5, 15, 30), stride: int = 10,
                 max_length: int = 60,
                 progress: Callable[[str], None] | None = None) -> Results:
    """Segment the pool once, fit each method per fold, score it on the fold's test takes."""
    from mimika.learn.train import Prepared, segment_takes

    seg, holds, trans = segment_takes(takes, max_length=max_length)
    rec: dict[str, list] = {k: [] for k in _FIELDS}
    win: dict[int, list] = {L: [[], []] for L in l2_lengths}
    for fold in folds:
        data = Prepared({n: takes[n] for n in (*fold.train, *fold.val, *fold.test)},
                        Split(fold.train, fold.val, fold.test), seg, holds, trans)
        gens = []
        for m in methods:
            if progress:
                progress(f"{fold.name}: fitting {m.name}")
            gens.append((m.fit(data), m.batched))
        items = data.items("test")
        _records(rec, fold.name, items, [_score(g, b, items) for g, b in gens], fold.channels)
        cols = np.isin(MODEL_CHANNELS, fold.channels)
        for L in l2_lengths:
            for n in fold.test:
                wins = fixed_windows(takes[n], L, stride=stride)
                outs = [_score(g, b, wins) for g, b in gens]
                win[L][0] += [n] * len(wins)
                win[L][1].append(np.array([[l2(o[j][:, cols], wins[j].frames[:, cols])
                                            for j in range(len(wins))] for o in outs]))
    windows = {L: (np.array(v[0]), np.concatenate(v[1], axis=1)) for L, v in win.items()}
    return _results([m.name for m in methods],
                    [m.name for m in methods if isinstance(m, Baseline)], rec, windows)


def merge_methods(a: Results, b: Results) -> Results:
    """One :class:`Results` with the methods of ``a`` and then ``b`` (the same transitions, as
    two runs of :func:`run_protocol` on the same pool and folds give)."""
    if not (np.array_equal(a.take, b.take) and np.array_equal(a.length, b.length)
            and np.array_equal(a.fold, b.fold)):
        raise ValueError("results cover different transitions; run them on one pool and folds")
    win = {L: (a.windows[L][0], np.concatenate([a.windows[L][1], b.windows[L][1]]))
           for L in a.windows if L in b.windows}
    return replace(a, methods=a.methods + b.methods, baselines=a.baselines + b.baselines,
                   se=np.concatenate([a.se, b.se]), l2=np.concatenate([a.l2, b.l2]),
                   jump=np.concatenate([a.jump, b.jump]),
                   consp=np.concatenate([a.consp, b.consp]),
                   onset=np.concatenate([a.onset, b.onset[1:]]),
                   peak=np.concatenate([a.peak, b.peak[1:]]), windows=win)


def concat(parts: Sequence[Results]) -> Results:
    """The transitions (and windows) of several runs of the same methods, one after another
    (e.g. one run per fold, cached separately)."""
    first = parts[0]
    if any(p.methods != first.methods for p in parts):
        raise ValueError("results of different methods cannot be concatenated")

    def cat(name: str, axis: int = 0) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in parts], axis=axis)

    win = {L: (np.concatenate([p.windows[L][0] for p in parts]),
               np.concatenate([p.windows[L][1] for p in parts], axis=1))
           for L in first.windows if all(L in p.windows for p in parts)}
    return replace(first, fold=cat("fold"), take=cat("take"), length=cat("length"),
                   size=cat("size"), count=cat("count"), gt_jump=cat("gt_jump"),
                   se=cat("se", 1), l2=cat("l2", 1), jump=cat("jump", 1), consp=cat("consp", 1),
                   onset=cat("onset", 1), peak=cat("peak", 1), windows=win)


def bootstrap(stat: Callable[[np.ndarray], float], strata: np.ndarray, *, n: int = 2000,
              seed: int = 0, level: float = 0.95) -> tuple[float, float]:
    """Percentile interval of ``stat(indices)`` over ``n`` resamples of the rows, drawn with
    replacement within each stratum (e.g. each test take keeps its number of transitions)."""
    rng = np.random.default_rng(seed)
    groups = [np.flatnonzero(strata == s) for s in np.unique(strata)]
    vals = np.array([stat(np.concatenate([rng.choice(g, len(g)) for g in groups]))
                     for _ in range(n)])
    q = (1 - level) / 2
    return float(np.nanquantile(vals, q)), float(np.nanquantile(vals, 1 - q))


def summarise(res: Results, *, n_boot: int = 2000, seed: int = 0) -> dict[str, Any]:
    """Per method: pooled MSE, its change vs the best baseline of this subset (paired), mean
    L2, jump % and conspicuous %, each with a 95 % interval; L2@N per window length; median
    onset latency and peak velocity per AU group (ground truth first). Empty subsets give
    ``{"n": 0}``."""
    n = len(res.take)
    if n == 0:
        return {"n": 0}
    s = res.take

    def mse(m):
        return lambda i: float(res.se[m, i].sum() / res.count[i].sum())

    base = [res.methods.index(b) for b in res.baselines]
    best = min(base, key=lambda m: mse(m)(np.arange(n))) if base else 0
    out: dict[str, Any] = {"n": n, "best_baseline": res.methods[best], "methods": {}}
    for m, name in enumerate(res.methods):
        def rel(i, m=m):
            return float(res.se[m, i].sum() / max(res.se[best, i].sum(), 1e-12) - 1)

        def mean_of(x):
            return lambda i: float(np.mean(x[i]))

        r = {"mse": mse(m)(np.arange(n)), "mse_ci": bootstrap(mse(m), s, n=n_boot, seed=seed),
             "rel": rel(np.arange(n)), "rel_ci": bootstrap(rel, s, n=n_boot, seed=seed)}
        for key, x in (("l2", res.l2[m]), ("jump", res.jump[m]),
                       ("consp", 100.0 * res.consp[m])):
            r[key] = float(np.mean(x))
            r[key + "_ci"] = bootstrap(mean_of(x), s, n=n_boot, seed=seed)
        r["consp_n"] = int(res.consp[m].sum())
        for L, (takes, v) in res.windows.items():
            r[f"l2@{L}"] = float(np.mean(v[m]))
            r[f"l2@{L}_ci"] = bootstrap(mean_of(v[m]), takes, n=n_boot // 4, seed=seed)
        out["methods"][name] = r
    with warnings.catch_warnings():  # a group no take has: its median is NaN, as meant
        warnings.simplefilter("ignore", RuntimeWarning)
        med = lambda x: np.nanmedian(x, axis=0).tolist()  # noqa: E731
        out["timing"] = {"groups": list(GROUPS),
                         "onset": {k: med(res.onset[j]) for j, k in
                                   enumerate(["ground truth", *res.methods])},
                         "peak": {k: med(res.peak[j]) for j, k in
                                  enumerate(["ground truth", *res.methods])}}
    out["gt_jump"] = float(np.mean(res.gt_jump))
    return out


def validation_record(res: Results, method: str, *, source: str, n_boot: int = 1000,
                      seed: int = 0) -> dict[str, Any]:
    """What the ``learned`` easing needs to decide, per transition size, whether to use the
    model or fall back to the best interpolator: for each of :data:`SIZE_BINS` the model's
    pooled MSE, the best baseline's, their relative difference with its interval, and
    ``use_model`` (the model was better; a bin without validation transitions falls back)."""
    m = res.methods.index(method)
    bins = []
    for name, lo, hi in SIZE_BINS:
        sub = res.size_bin(name)
        entry: dict[str, Any] = {"name": name, "lo": lo, "hi": hi, "n": len(sub.take),
                                 "use_model": False, "baseline": None}
        if len(sub.take):
            s = summarise(sub, n_boot=n_boot, seed=seed)
            b = s["best_baseline"]
            entry.update(baseline=b, baseline_mse=s["methods"][b]["mse"],
                         model_mse=s["methods"][method]["mse"], rel=s["methods"][method]["rel"],
                         rel_ci=list(s["methods"][method]["rel_ci"]),
                         use_model=bool(sub.se[m].sum() < sub.se[res.methods.index(b)].sum()))
        bins.append(entry)
    return {"source": source, "method": method, "bins": bins}
