"""The latent-slider controller: a trained generator of AU frames behind a few sliders.

``Controller.load()`` opens the model shipped with mimika — the Wasserstein auto-encoder
(``learn/data/controller.pt``, :mod:`mimika.learn.wae`); ``load("seed")`` seed 001's WGAN
(``gan.pt``), ``conditional=True`` the conditional WGAN-GP (``cgan.pt``);
``.sample(z, label=None)`` returns blended AU intensities for one slider setting. Every
generated frame is de-normalised
(``x = G(z)·σ + μ``), clamped to [0, 1] and passed through the AU Blender before use.

>>> c = Controller.load()                       # doctest: +SKIP
>>> c.sample([0.0, 1.5, 0.0, -1.0])             # doctest: +SKIP
{'AU01': 0.02, ...}
"""

from __future__ import annotations

import difflib
import logging
import os
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from mimika.errors import DataError, ParameterError

log = logging.getLogger(__name__)

__all__ = ["SHIPPED", "TRAVERSAL", "Controller", "shipped_model"]

#: the models that ship with the package (in ``mimika/learn/data``), by name
SHIPPED = {"wae": "controller.pt", "wgan": "gan.pt", "cgan": "cgan.pt"}
#: other names of shipped models
ALIASES = {"default": "wae", "builtin": "wae", "seed": "wgan", "conditional": "cgan"}
#: slider values of a traversal grid's columns (seed 001: −3 … 3; covers 99.7 % of N(0, 1))
TRAVERSAL = (-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0)
Progress = Callable[[int, int], None]


def shipped_model(conditional: bool = False, name: str = "wae") -> Path:
    """Path of a shipped model: ``name`` (see :data:`SHIPPED`, :data:`ALIASES`), or the
    conditional one."""
    key = "cgan" if conditional else ALIASES.get(name, name)
    if key not in SHIPPED:
        raise ParameterError(f"unknown model {name!r}: the shipped ones are "
                             f"{', '.join([*SHIPPED, *ALIASES])}, or give a checkpoint path")
    name = SHIPPED[key]
    p = Path(str(resources.files("mimika.learn").joinpath("data", name)))
    if not p.is_file():
        raise DataError(f"the shipped model {name} is missing from this installation ({p}); "
                        "reinstall mimika or train one with 'mimika train gan'")
    return p


class Controller:
    """A trained generator with its normalisation, channels and (conditional) labels."""

    def __init__(self, state: dict[str, Any], *, path: str | os.PathLike | None = None):
        import torch

        from mimika.learn.cgan import CondGenerator
        from mimika.learn.inversion import Encoder
        from mimika.learn.wae import WAEDecoder, WAEEncoder
        from mimika.learn.wgan import Generator

        self.path = Path(path) if path is not None else None
        self.kind: str = state["kind"]
        self.config: dict[str, Any] = dict(state["config"])
        self.channels: tuple[str, ...] = tuple(state["channels"])
        self.fps: float = float(state.get("fps", 30.0))
        self.labels: tuple[str, ...] = tuple(state.get("labels", ()))
        self.meta: dict[str, Any] = dict(state.get("meta", {}))
        self.history: dict[str, Any] = dict(state.get("history", {}))
        self.mean = np.asarray(state["mean"], np.float32)
        self.std = np.asarray(state["std"], np.float32)
        K, d = len(self.channels), int(self.config["latent_dim"])
        cfg = self.config
        if self.kind == "wgan":
            self._g = Generator(d, K, cfg["hidden"], cfg["leak"])
        elif self.kind == "cgan":
            self._g = CondGenerator(d, K, len(self.labels), cfg["hidden"], cfg["embed"],
                                    cfg["leak"])
        elif self.kind == "wae":
            self._g = WAEDecoder(d, K, cfg["hidden"], cfg["leak"])
        else:
            raise DataError(f"unknown model kind {self.kind!r} (expected wae, wgan or cgan)")
        try:
            self._g.load_state_dict(state["generator"])
        except RuntimeError as e:
            raise DataError(f"generator weights do not match the config: {e}") from None
        self._g.eval()
        self._enc = None
        if state.get("encoder"):
            self._enc = (WAEEncoder(K, d, cfg["hidden"], cfg["leak"]) if self.kind == "wae"
                         else Encoder(K, d, len(self.labels) if self.kind == "cgan" else 0))
            self._enc.load_state_dict(state["encoder"])
            self._enc.eval()
        self._torch = torch

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | os.PathLike | None = None, *,
             conditional: bool = False) -> Controller:
        """Load a checkpoint path or a shipped model's name (default: the WAE; ``"seed"``:
        seed 001's WGAN; ``conditional`` picks the conditional WGAN-GP)."""
        from mimika.learn.wgan import load_checkpoint

        if path is None or str(path) in (*SHIPPED, *ALIASES):
            p = shipped_model(conditional, "wae" if path is None else str(path))
        else:
            p = Path(path)
        return cls(load_checkpoint(p), path=p)

    def __repr__(self) -> str:
        lab = f", labels={list(self.labels)}" if self.labels else ""
        return (f"Controller({self.kind}, latent_dim={self.latent_dim}, "
                f"{len(self.channels)} channels{lab})")

    @property
    def latent_dim(self) -> int:
        return int(self.config["latent_dim"])

    @property
    def conditional(self) -> bool:
        return self.kind == "cgan"

    # -- validation ---------------------------------------------------------------------------
    def check_z(self, z: Sequence[float] | np.ndarray) -> np.ndarray:
        """``z`` as float32 (N, d); raises :class:`ParameterError` on a wrong length."""
        a = np.asarray(z, np.float32)
        if a.ndim == 1:
            a = a[None]
        if a.ndim != 2 or a.shape[1] != self.latent_dim:
            n = a.shape[-1] if a.ndim else 1
            raise ParameterError(f"z has {n} value(s) but the model has {self.latent_dim} "
                                 f"latent sliders (e.g. --z {','.join(['0'] * self.latent_dim)})")
        if not np.all(np.isfinite(a)):
            raise ParameterError("z contains NaN or infinity")
        return a

    def label_index(self, label: str | None) -> int | None:
        """Index of ``label`` in :attr:`labels` (None for none); unknown labels raise."""
        if label is None:
            if self.conditional:
                return self.labels.index("neutral") if "neutral" in self.labels else 0
            return None
        if not self.conditional:
            raise ParameterError(f"label {label!r} given, but this model is unconditional; use "
                                 "the conditional model (--conditional / a cgan checkpoint)")
        if label not in self.labels:
            close = difflib.get_close_matches(label, self.labels, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ParameterError(f"unknown label {label!r}: the model knows "
                                 f"{', '.join(self.labels)}{hint}")
        return self.labels.index(label)

    def _labels(self, label: str | Sequence[str] | None, n: int):
        if not self.conditional:
            if label is not None:
                self.label_index(label if isinstance(label, str) else label[0])
            return None
        if label is None or isinstance(label, str):
            return self._torch.full((n,), self.label_index(label), dtype=self._torch.long)
        idx = [self.label_index(lab) for lab in label]
        if len(idx) != n:
            raise ParameterError(f"{len(idx)} labels for {n} latent vectors")
        return self._torch.tensor(idx, dtype=self._torch.long)

    # -- generation ---------------------------------------------------------------------------
    def _gen(self, z, y):
        return self._g(z) if y is None else self._g(z, y)

    def generate(self, z: Sequence[float] | np.ndarray,
                 label: str | Sequence[str] | None = None) -> np.ndarray:
        """Generated frames before blending: z (N, d) → (N, K) in [0, 1] over :attr:`channels`."""
        a = self.check_z(z)
        y = self._labels(label, len(a))
        with self._torch.no_grad():
            out = self._gen(self._torch.from_numpy(a), y).numpy()
        return np.clip(out * self.std + self.mean, 0.0, 1.0).astype(np.float32)

    def generate_blended(self, z: Sequence[float] | np.ndarray,
                         label: str | Sequence[str] | None = None
                         ) -> tuple[np.ndarray, tuple[str, ...]]:
        """Generated frames through the AU Blender: (N, K') and their channels."""
        from mimika.facs.blender import blend_frames

        return blend_frames(self.generate(z, label), self.channels)

    def sample(self, z: Sequence[float] | np.ndarray,
               label: str | None = None) -> dict[str, float]:
        """One slider setting ``z`` (d,) → blended AU intensities ``{code: value in [0, 1]}``."""
        a = self.check_z(z)
        if len(a) != 1:
            raise ParameterError(f"sample takes one latent vector, got {len(a)}")
        vals, chans = self.generate_blended(a, label)
        return {c: round(float(v), 6) for c, v in zip(chans, vals[0], strict=True)}

    def random(self, n: int, *, label: str | Sequence[str] | None = None,
               seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """``n`` random draws ``z ~ N(0, I)``: returns (z (n, d), frames (n, K), not blended)."""
        z = np.random.default_rng(seed).standard_normal((n, self.latent_dim)).astype(np.float32)
        return z, self.generate(z, label)

    def traversal(self, values: Sequence[float] = TRAVERSAL, *,
                  label: str | None = None) -> np.ndarray:
        """Each latent variable swept over ``values``, the others 0: (d, len(values), K)."""
        v = np.asarray(values, np.float32)
        d = self.latent_dim
        z = np.zeros((d, len(v), d), np.float32)
        for i in range(d):
            z[i, :, i] = v
        return self.generate(z.reshape(-1, d), label).reshape(d, len(v), -1)

    # -- inversion ----------------------------------------------------------------------------
    def invert_batch(self, frames: np.ndarray, labels: Sequence[str] | None = None, *,
                     steps: int = 200, restarts: int = 6, seed: int = 0,
                     fit: np.ndarray | None = None, peak: float | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
        """Real frames (N, K) over :attr:`channels` → (z (N, d), reconstructions (N, K));
        ``fit`` (K,) bool: fit only these channels (e.g. those another rig carries); ``peak``:
        errors weighted ``1 + peak·x`` (default: as the model was trained, WAE 4, GANs 0)."""
        from mimika.learn.inversion import invert_frames

        x = np.asarray(frames, np.float32)
        if x.ndim != 2 or x.shape[1] != len(self.channels):
            raise ParameterError(f"frames must have shape (N, {len(self.channels)}), got "
                                 f"{x.shape}")
        if self.conditional:
            if labels is None:
                from mimika.learn.gan_data import LABELS, prototype_labels

                names = [LABELS[i] for i in prototype_labels(x, self.channels)]
                labels = [n if n in self.labels else self.labels[0] for n in names]
            y = self._labels(list(labels), len(x)).numpy()
        else:
            self._labels(None if labels is None else list(labels), len(x))
            y = None
        return invert_frames(self._gen, np.clip(x, 0.0, 1.0), self.mean, self.std,
                             latent_dim=self.latent_dim, labels=y, encoder=self._enc,
                             steps=steps, restarts=restarts, seed=seed, channels=fit,
                             peak=self.config.get("peak", 0.0) if peak is None else peak)

    def invert(self, frame: dict[str, float] | Sequence[float] | np.ndarray,
               label: str | None = None, **kwargs: Any) -> np.ndarray:
        """A frame (``{code: value}`` or (K,) over :attr:`channels`) → latent sliders z (d,)."""
        x = self.frame_vector(frame)
        z, _ = self.invert_batch(x[None], None if label is None else [label], **kwargs)
        return z[0]

    def frame_vector(self, frame: dict[str, float] | Sequence[float] | np.ndarray
                     ) -> np.ndarray:
        """``{code: value}`` (folded onto the model channels) or a (K,) array → (K,) float32."""
        if isinstance(frame, dict):
            from mimika.facs import parse_au
            from mimika.learn.data import fold_channels

            codes = [parse_au(c) for c in frame]
            return fold_channels(np.array([list(frame.values())], np.float32), codes,
                                 self.channels)[0]
        x = np.asarray(frame, np.float32)
        if x.shape != (len(self.channels),):
            raise ParameterError(f"frame has shape {x.shape}, expected ({len(self.channels)},) "
                                 f"over {', '.join(self.channels)}")
        return x

    # -- rendering ----------------------------------------------------------------------------
    def traversal_images(self, *, head: Any = None, values: Sequence[float] = TRAVERSAL,
                         label: str | None = None, tile: tuple[int, int] = (160, 160),
                         view: str = "front", progress: Progress | None = None
                         ) -> list[np.ndarray]:
        """Each slider swept over ``values`` (the others 0), rendered on ``head`` (a head
        spec or a rig; default: the default head): a list of ``latent_dim × len(values)``
        (H, W, 3) uint8 images, slider by slider."""
        from mimika.facs.blender import blend_frames
        from mimika.render import Renderer

        rig = _rig(head)
        grid = self.traversal(values, label=label)  # (d, n, K)
        d, n, _ = grid.shape
        flat, chans = blend_frames(grid.reshape(d * n, -1), self.channels)
        images = []
        with Renderer(rig.head, size=tile) as r:
            for k in range(d * n):
                aus = _supported(dict(zip(chans, flat[k].tolist(), strict=True)), rig)
                images.append(r.render(rig.deform(aus), view=view, aus=aus))
                if progress:
                    progress(k + 1, d * n)
        return images

    def render_grid(self, *, head: Any = None, values: Sequence[float] = TRAVERSAL,
                    label: str | None = None, tile: tuple[int, int] = (160, 160),
                    view: str = "front", title: str | None = None,
                    progress: Progress | None = None) -> np.ndarray:
        """Latent traversal grid on a head: rows = latent variables, columns = ``values``.

        Returns an (H, W, 3) uint8 contact sheet of ``latent_dim × len(values)`` tiles.
        """
        from mimika.render import contact_sheet

        images = self.traversal_images(head=head, values=values, label=label, tile=tile,
                                       view=view, progress=progress)
        d, n = self.latent_dim, len(values)
        names = [f"z{k // n + 1}={values[k % n]:+g}" for k in range(d * n)]
        if title is None:
            what = f"label {label}" if label else self.kind.upper()
            title = (f"mimika - latent traversal ({what}): rows z1..z{d}, columns "
                     f"{values[0]:g} .. {values[-1]:g}, others 0")
        return contact_sheet(images, names, columns=n, title=title)

    def render(self, z: Sequence[float] | np.ndarray, *, label: str | None = None,
               head: Any = None, size: tuple[int, int] = (640, 480),
               view: str = "front") -> np.ndarray:
        """One slider setting rendered on ``head``: (H, W, 3) uint8."""
        from mimika.render import Renderer

        rig = _rig(head)
        aus = _supported(self.sample(z, label), rig)
        with Renderer(rig.head, size=size) as r:
            return r.render(rig.deform(aus), view=view, aus=aus)


def _rig(head: Any):
    """The rig of ``head``: a rig as is, a head spec loaded, None the default head."""
    from mimika.face.rig import Rig

    if isinstance(head, Rig):
        return head
    from mimika.face.heads import load_head

    return (load_head() if head is None else load_head(head))[1]


def _supported(aus: dict[str, float], rig) -> dict[str, float]:
    """Drop AUs the head does not model (e.g. AU11, AU14 on the built-in head)."""
    sup = set(rig.supported)
    drop = [c for c in aus if c not in sup]
    if drop:
        log.debug("head %s does not model %s; left out", rig.head.name, ", ".join(drop))
    return {c: min(max(v, 0.0), 1.0) for c, v in aus.items() if c in sup}


def train_controller(data: str | os.PathLike | None = None, *, latent_dim: int = 4,
                     n_critic: int | None = None, iters: int | None = None,
                     conditional: bool = False, test_takes: Sequence[str] | None = None,
                     seed: int = 0, encoder_steps: int = 3000,
                     classifier: float | None = None,
                     progress: Progress | None = None) -> tuple[dict[str, Any], Any]:
    """Train a controller on a folder of takes (default ``$MIMIKA_MOTION_DIR``).

    Splits by take (``test_takes``, default ``apfel``; none when the folder lacks it), trains
    the seed's WGAN (or, ``conditional``, the WGAN-GP with emotion labels and an auxiliary
    classifier of weight ``classifier``, default 10), fits the inversion
    encoder and returns ``(checkpoint dict, training result)`` — save it with
    :func:`mimika.learn.wgan.save_checkpoint`.
    """
    from mimika.learn.gan_data import LABELS, TEST_TAKES, load_frames
    from mimika.learn.inversion import fit_encoder

    fs = load_frames(data)
    tests = [t for t in (TEST_TAKES if test_takes is None else test_takes) if t in fs.takes]
    if test_takes is not None and len(tests) != len(test_takes):
        raise ParameterError(f"test take(s) {', '.join(test_takes)} not among "
                             f"{', '.join(fs.takes)}")
    if tests and len(tests) < len(fs.takes):
        train, test = fs.split(tests)
    else:
        train, test = fs, None
    meta = {"data": str(fs.meta.get("folder", "")), "train_takes": sorted(
        {fs.takes[i] for i in np.unique(train.take)}), "test_takes": tests,
        "train_frames": len(train), "test_frames": 0 if test is None else len(test),
        "preprocessing": "fold to 20 bilateral face AUs; subtract per-take median frame; "
                         "clip to [0, 1]; z-score with the training mean/std",
        "label_counts": train.label_counts()}
    if conditional:
        from mimika.learn.cgan import CGANConfig, cgan_state, train_cgan

        cfg = CGANConfig(latent_dim=latent_dim, seed=seed)
        if n_critic is not None:
            cfg.n_critic = n_critic
        if iters is not None:
            cfg.iters = iters
        if classifier is not None:
            cfg.classifier = classifier
        res = train_cgan(train.values, train.labels, LABELS,
                         None if test is None else test.values,
                         None if test is None else test.labels, cfg, progress=progress)
        state = cgan_state(res, channels=fs.channels, fps=fs.fps, meta=meta)
        G = res.generator

        def gen(z, y):
            return G(z, y)
        n_labels = len(LABELS)
    else:
        from mimika.learn.wgan import WGANConfig, train_wgan, wgan_state

        cfg = WGANConfig(latent_dim=latent_dim, seed=seed)
        if n_critic is not None:
            cfg.n_critic = n_critic
        if iters is not None:
            cfg.iters = iters
        res = train_wgan(train.values, None if test is None else test.values, cfg,
                         progress=progress)
        state = wgan_state(res, channels=fs.channels, fps=fs.fps, meta=meta)
        G = res.generator

        def gen(z, y):
            return G(z)
        n_labels = 0
    enc = fit_encoder(gen, latent_dim, len(fs.channels), n_labels, steps=encoder_steps,
                      seed=seed)
    state["encoder"] = {k: v.clone() for k, v in enc.state_dict().items()}
    return state, res
