"""Streaming lip-sync recognition: mouth classes from audio, frame by frame, each decision
final after a fixed look-ahead (:attr:`Recogniser.lookahead`: 72.5 ms).

Three stages, each fed as audio arrives and each exactly as it would be on the whole
recording (so :func:`recognise_classes` offline and :class:`Recogniser` fed in chunks of any
size give the same classes):

* :class:`Features` — 100 frames per second of log-mel energies (25 ms Hamming window at the
  recording's own rate, 40 bands 60–7600 Hz): the spectral shape (each band minus the frame's
  mean) and the frame's log energy. No resampling; nothing normalised per recording.
* :class:`Model` — a small MLP over the frames ``offsets`` around each frame (a few past
  frames, :data:`~Model.right` future ones) giving log-posteriors of mimika's phoneme classes
  (``speech/data/visemes.json``: bilabial, labiodental, vowel_open …). Its weights
  (``speech/data/mouth_classes.npz``) were trained by ``bench/train_mouth_classes.py`` on
  GRID speaker s1 (Cooke, Barker, Cunningham & Shao 2006, CC BY 4.0; labels from
  transcript-aligned phones) and on synthetic sentences of the Piper voice en_US-joe-medium
  (CC0) and espeak-ng (labels from their own timing); the file lists its training
  utterances and provenance (``Model.meta``).
* :class:`Decoder` — fixed-lag Viterbi over those posteriors (a switch between classes costs
  ``switch``): frame *t* is decided when frame *t + lag* has been scored, and never revised.

A frame's class is final ``Model.right + lag`` frames plus half a window (12.5 ms) after its
centre.
"""

from __future__ import annotations

import functools
import json
import math
from importlib import resources
from typing import Any

import numpy as np

from mimika.errors import ParameterError
from mimika.speech.utterance import Phone

RATE = 100  #: class decisions per second
N_MELS = 40
WINDOW = 0.025  #: analysis window (s)
F_LO, F_HI = 60.0, 7600.0
PRE = 0.97  #: pre-emphasis
FLOOR = 1e-10  #: power floor (digital silence)
MODEL = "data/mouth_classes.npz"
#: one espeak-ng mnemonic per class: recognised class segments become these phones
SYMBOL = {"sil": "_", "bilabial": "p", "labiodental": "f", "dental": "T", "alveolar": "t",
          "nasal": "n", "lateral": "l", "sibilant": "s", "postalveolar": "S", "velar": "k",
          "glottal": "h", "rhotic": "r", "rhotic_uvular": 'r"', "palatal_glide": "j",
          "labiovelar": "w",
          "vowel_open": "a", "vowel_mid_front": "E", "vowel_close_front": "i",
          "vowel_mid_central": "@", "vowel_mid_back_rounded": "O",
          "vowel_close_back_rounded": "u", "vowel_front_rounded": "y"}


@functools.cache
def _filterbank(sr: int, nfft: int, warp: float = 1.0) -> np.ndarray:
    """Triangular mel filters, shape (nfft // 2 + 1, N_MELS); bands above Nyquist are 0.
    ``warp`` scales every band's frequencies (training only: another vocal tract length)."""
    def mel(f: np.ndarray | float) -> np.ndarray:
        return 1127.0 * np.log1p(np.asarray(f) / 700.0)

    edges = warp * 700.0 * np.expm1(np.linspace(mel(F_LO), mel(F_HI), N_MELS + 2) / 1127.0)
    f = np.arange(nfft // 2 + 1) * sr / nfft
    lo, mid, hi = edges[:-2, None], edges[1:-1, None], edges[2:, None]
    w = np.maximum(0.0, np.minimum((f - lo) / (mid - lo), (hi - f) / (hi - mid)))
    return np.ascontiguousarray(w.T, np.float32)


class Features:
    """Streaming log-mel features at :data:`RATE` frames per second of audio at ``sr``.

    Frame *i* is centred on ``(i + 0.5) / RATE`` s (audio before the first sample is silence)
    and needs audio up to half a window past that. Rows: 40 band values minus their mean, then
    the log energy.
    """

    def __init__(self, sr: int, *, warp: float = 1.0):
        if not 4000 <= sr <= 192000:
            raise ParameterError(f"sample rate {sr} Hz must be within 4000…192000 Hz")
        self.sr = int(sr)
        self.win = round(WINDOW * sr)
        self.nfft = 1 << (self.win - 1).bit_length()
        self.window = np.hamming(self.win).astype(np.float32)
        self.norm = float(np.sum(self.window ** 2))
        self.fb = _filterbank(self.sr, self.nfft, warp)
        self.pad = self.win  # leading silence so frame 0's window starts inside the buffer
        self.buf = np.zeros(self.pad, np.float32)  # pre-emphasised samples from buf_start
        self.buf_start = -self.pad  # stream sample index of buf[0]
        self.last = 0.0  # last raw sample (pre-emphasis state)
        self.n = 0  # frames produced

    def _start(self, i: int) -> int:
        """Stream sample index where frame ``i``'s window starts."""
        return math.floor((i + 0.5) * self.sr / RATE - self.win / 2 + 0.5)

    def push(self, audio: np.ndarray, *, final: bool = False) -> np.ndarray:
        """Add samples; the frames whose window is now complete, shape (n, N_MELS + 1).

        With ``final`` the stream ends: frames up to the last sample's are produced (their
        windows end in silence)."""
        a = np.asarray(audio, np.float32).ravel()
        if len(a):
            e = np.empty_like(a)
            e[0] = a[0] - PRE * self.last
            e[1:] = a[1:] - PRE * a[:-1]
            self.last = float(a[-1])
            self.buf = np.concatenate([self.buf, e])
        end = self.buf_start + len(self.buf)  # stream samples seen
        if final:
            n_end = max(self.n, math.ceil(end * RATE / self.sr - 1e-9))
            need = self._start(n_end - 1) + self.win if n_end > self.n else end
            if need > end:
                self.buf = np.concatenate([self.buf, np.zeros(need - end, np.float32)])
        else:
            # frames i with _start(i) + win <= end
            n_end = self.n
            while self._start(n_end) + self.win <= end:
                n_end += 1
        if n_end <= self.n:
            return np.zeros((0, N_MELS + 1), np.float32)
        idx = np.array([self._start(i) for i in range(self.n, n_end)]) - self.buf_start
        frames = self.buf[idx[:, None] + np.arange(self.win)[None, :]] * self.window
        spec = np.fft.rfft(frames, self.nfft)
        power = (spec.real ** 2 + spec.imag ** 2).astype(np.float32) / self.norm
        mel = np.log(power @ self.fb + FLOOR)
        energy = np.log(power.sum(axis=1) + FLOOR)
        self.n = n_end
        drop = self._start(n_end) - self.buf_start
        if drop > 0:
            self.buf = self.buf[drop:]
            self.buf_start += drop
        return np.concatenate([mel - mel.mean(axis=1, keepdims=True), energy[:, None]],
                              axis=1).astype(np.float32)

    @property
    def delay(self) -> float:
        """Seconds of audio past a frame's centre that its window needs."""
        return self.win / 2 / self.sr


class Model:
    """The class MLP: log-posteriors of each frame from the frames at ``offsets`` around it."""

    def __init__(self, data: dict[str, Any]):
        self.classes: list[str] = [str(c) for c in data["classes"]]
        self.offsets = np.asarray(data["offsets"], int)
        self.mean = np.asarray(data["mean"], np.float32)
        self.scale = 1.0 / np.asarray(data["std"], np.float32)
        self.layers = [(np.asarray(data[f"w{i}"], np.float32), np.asarray(data[f"b{i}"],
                                                                        np.float32))
                       for i in range(int(data["n_layers"]))]
        self.log_prior = np.asarray(data["log_prior"], np.float32)
        self.meta: dict[str, Any] = json.loads(str(data["meta"]))
        self.left = int(-self.offsets.min())
        self.right = int(self.offsets.max())

    def scores(self, feats: np.ndarray) -> np.ndarray:
        """Log-posteriors for the frames that have their whole context in ``feats`` (rows
        ``left`` … ``len - right - 1``), shape (n, classes)."""
        n = len(feats) - self.left - self.right
        if n <= 0:
            return np.zeros((0, len(self.classes)), np.float32)
        x = (feats - self.mean) * self.scale
        rows = np.arange(n)[:, None] + (self.offsets + self.left)[None, :]
        h = x[rows].reshape(n, -1)
        for k, (w, b) in enumerate(self.layers):
            h = h @ w + b
            if k < len(self.layers) - 1:
                np.maximum(h, 0.0, out=h)
        h -= h.max(axis=1, keepdims=True)
        return h - np.log(np.exp(h).sum(axis=1, keepdims=True))


@functools.cache
def model() -> Model:
    """The shipped class model (``speech/data/mouth_classes.npz``)."""
    with (resources.files("mimika.speech").joinpath(MODEL).open("rb") as f,
          np.load(f, allow_pickle=False) as z):
        return Model({k: z[k] for k in z.files})


class Decoder:
    """Fixed-lag Viterbi over per-frame class log-scores: one path through the classes, a
    switch costing ``switch``; frame *t* is decided (by backtracking from the best state)
    once frame *t + lag* is in, and never revised."""

    def __init__(self, n_classes: int, *, lag: int, switch: float, prior_weight: float,
                 log_prior: np.ndarray, start: int = 0):
        self.lag, self.switch = lag, switch
        self.bias = -prior_weight * log_prior
        self.score = np.full(n_classes, -switch, np.float64)
        self.score[start] = 0.0  # a stream starts silent
        self.back: list[np.ndarray] = []  # back-pointers of the undecided frames

    def push(self, logp: np.ndarray, *, final: bool = False) -> list[int]:
        """Score new frames; the classes of the frames now decided, in order."""
        out: list[int] = []
        for row in logp + self.bias:
            best = int(np.argmax(self.score))
            switch = self.score[best] - self.switch
            stay = self.score >= switch
            self.back.append(np.where(stay, np.arange(len(row)), best))
            self.score = np.where(stay, self.score, switch) + row
            self.score -= self.score.max()
            if len(self.back) > self.lag:
                out.append(self._decide())
        if final:
            while self.back:
                out.append(self._decide())
        return out

    def _decide(self) -> int:
        """Decide the oldest undecided frame: backtrack to it from the best state now."""
        state = int(np.argmax(self.score))
        for j in range(len(self.back) - 1, 0, -1):
            state = int(self.back[j][state])
        self.back.pop(0)
        return state


class Recogniser:
    """Audio in chunks of any size → the classes of the frames now final (one per
    1 / :data:`RATE` s, from the stream's start)."""

    def __init__(self, sr: int):
        self.model = model()
        dec = self.model.meta["decoder"]
        self.features = Features(sr)
        self.feats = np.zeros((self.model.left, N_MELS + 1), np.float32)  # context rows
        self.started = False
        self.decoder = Decoder(len(self.model.classes),
                               lag=dec["lag"], switch=dec["switch"],
                               prior_weight=dec["prior_weight"],
                               log_prior=self.model.log_prior,
                               start=self.model.classes.index("sil"))
        self.n = 0  # frames decided

    @property
    def lookahead(self) -> float:
        """Seconds of audio past a frame's centre before its class is final."""
        return (self.model.right + self.decoder.lag) / RATE + self.features.delay

    def push(self, audio: np.ndarray, *, final: bool = False) -> list[str]:
        """Add samples; the classes now final."""
        new = self.features.push(audio, final=final)
        if len(new) and not self.started:  # the past before the stream: its first frame
            self.feats[:] = new[0]
            self.started = True
        feats = np.concatenate([self.feats, new])
        if final and len(feats) > self.model.left:  # the future after it: its last frame
            feats = np.concatenate([feats, np.repeat(feats[-1:], self.model.right, axis=0)])
        logp = self.model.scores(feats)
        keep = self.model.left + self.model.right
        self.feats = feats[len(logp):][-keep:] if not final else feats[:0]
        out = self.decoder.push(logp, final=final)
        self.n += len(out)
        return [self.model.classes[c] for c in out]


def class_phones(classes: list[str], *, start: int = 0) -> list[Phone]:
    """Runs of equal frame classes (frame *k* = ``start + k``) as phones tiling their time
    (vowels stressed: no transcript tells which are)."""
    out: list[Phone] = []
    k = 0
    while k < len(classes):
        j = k
        while j < len(classes) and classes[j] == classes[k]:
            j += 1
        sym = SYMBOL[classes[k]]
        stress = 2 if classes[k].startswith("vowel_") else 0
        out.append(Phone(sym, (start + k) / RATE, (start + j) / RATE, stress))
        k = j
    return out


def recognise_classes(audio: np.ndarray, *, sr: int, chunk_s: float = 5.0) -> list[str]:
    """The class of every 1 / :data:`RATE` s of a whole recording (as a stream would get
    them), fed in chunks of ``chunk_s`` seconds so memory stays flat for long recordings."""
    rec, step = Recogniser(sr), max(1, int(chunk_s * sr))
    out: list[str] = []
    for i in range(0, max(len(audio), 1), step):
        out += rec.push(audio[i:i + step], final=i + step >= len(audio))
    return out
