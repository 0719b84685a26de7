"""FieldRig — seed 002's facial model: Action Units as displacement fields over space.

A linear AU moves a point v by Δv = Ψ(v)·φ(v)·τ (Eq 4.1) where τ ∈ [0, 1] is the intensity,
Ψ a unit direction whose polar angles are cubic polynomials of the position (Eq 4.3–4.5) and
φ a sum of Gaussians (Eq 4.6–4.7). Rotation AUs (head 51–56, eyes 61–64) rotate points about a
pivot by an angle that grows with τ, weighted by a fall-off (1 on the head, 0 below the neck).
Because fields are functions of space, one parameter file deforms any mesh of a similar face.

Parameter files (JSON, ``format: "mimika-fields"``) hold, per AU, one field per object category
(face, eyes, teeth — seed Table 4.2). Sub-object AUs (10, 16, 18, 22, 25, 27, 28) have an
``upper`` and a ``lower`` field; a point uses the one of the side of the mouth-corner plane it
starts on. See ``docs/rigs.md`` for the schema.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from importlib import resources
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from mimika.errors import DataError, ParameterError
from mimika.face.head import Head
from mimika.face.rig import Positions, Rig, split_sides
from mimika.facs import AU_CATALOGUE, parse_au
from mimika.limits import loads_json

log = logging.getLogger(__name__)

MIXERS = ("additive", "successive")
#: Softness (cm) of the left/right masks used for unilateral variants.
SIDE_SOFTNESS = 0.5
#: cm: skin within this distance of an eyeball's sphere at rest counts as lid (slides over it)
LID_BAND = 0.35


# --- the function families (pure array functions) ----------------------------------------------


@dataclass(frozen=True)
class Cubic:
    """A cubic polynomial of position: (u·A1·u)(A2·u) + u·A3·u + A4·u + c (seed Eq 4.4)."""

    A1: np.ndarray  # (3, 3)
    A2: np.ndarray  # (3,)
    A3: np.ndarray  # (3, 3)
    A4: np.ndarray  # (3,)
    c: float

    @classmethod
    def from_json(cls, d: Mapping | float | None) -> Cubic:
        if d is None or isinstance(d, int | float):
            d = {"c": float(d or 0.0)}
        z33, z3 = np.zeros((3, 3)), np.zeros(3)
        return cls(
            np.asarray(d.get("A1", z33), float).reshape(3, 3),
            np.asarray(d.get("A2", z3), float).reshape(3),
            np.asarray(d.get("A3", z33), float).reshape(3, 3),
            np.asarray(d.get("A4", z3), float).reshape(3),
            float(d.get("c", 0.0)),
        )

    def to_json(self) -> dict:
        out: dict = {}
        for k in ("A1", "A2", "A3", "A4"):
            a = getattr(self, k)
            if np.any(a):
                out[k] = np.round(a, 8).tolist()
        out["c"] = round(self.c, 8)
        return out

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Evaluate at points ``u`` (shape (N, 3)); returns shape (N,)."""
        out = np.full(u.shape[0], self.c)
        if np.any(self.A1) and np.any(self.A2):
            out += np.einsum("ni,ij,nj->n", u, self.A1, u) * (u @ self.A2)
        if np.any(self.A3):
            out += np.einsum("ni,ij,nj->n", u, self.A3, u)
        if np.any(self.A4):
            out += u @ self.A4
        return out


@dataclass(frozen=True)
class Gaussian:
    """η·exp(−(u−m)ᵀB(u−m)/2) (seed Eq 4.6)."""

    eta: float
    mean: np.ndarray  # (3,)
    B: np.ndarray  # (3, 3) symmetric positive semi-definite

    @classmethod
    def from_json(cls, d: Mapping) -> Gaussian:
        if not {"eta", "mean"} <= set(d) or not {"sigma", "B"} & set(d):
            raise ValueError(f"a phi Gaussian needs eta, mean and sigma (or B); got {sorted(d)}")
        if "sigma" in d:
            s = np.broadcast_to(np.asarray(d["sigma"], float), (3,))
            if np.any(s <= 0):
                raise ValueError(f"sigma={list(s)} must be > 0")
            B = np.diag(1.0 / s**2)
        else:
            B = np.asarray(d["B"], float).reshape(3, 3)
        return cls(float(d["eta"]), np.asarray(d["mean"], float).reshape(3), B)

    def to_json(self) -> dict:
        return {"eta": round(self.eta, 8), "mean": np.round(self.mean, 6).tolist(),
                "B": np.round(self.B, 8).tolist()}

    def __call__(self, u: np.ndarray) -> np.ndarray:
        d = u - self.mean
        return self.eta * np.exp(-0.5 * np.einsum("ni,ij,nj->n", d, self.B, d))


@dataclass(frozen=True)
class Rbf:
    """A smooth vector residual Σₖ wₖ·exp(−|u−cₖ|²/(2σ²)) (an extension: the fitted ``rich``
    family adds it to Ψ·φ; see docs/fitting.md). centers (K, 3), weights (K, 3), σ in u units."""

    centers: np.ndarray
    weights: np.ndarray
    sigma: float

    @classmethod
    def from_json(cls, d: Mapping) -> Rbf:
        c = np.asarray(d["centers"], float).reshape(-1, 3)
        w = np.asarray(d["weights"], float).reshape(-1, 3)
        if len(c) != len(w):
            raise ValueError(f"rbf has {len(c)} centers but {len(w)} weights")
        if float(d["sigma"]) <= 0:
            raise ValueError(f"rbf sigma={d['sigma']} must be > 0")
        return cls(c, w, float(d["sigma"]))

    def to_json(self) -> dict:
        return {"sigma": round(self.sigma, 8), "centers": np.round(self.centers, 6).tolist(),
                "weights": np.round(self.weights, 8).tolist()}

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Residual displacements at points ``u`` (N, 3), shape (N, 3)."""
        c = self.centers
        d2 = (u * u).sum(1)[:, None] + (c * c).sum(1)[None, :] - 2.0 * (u @ c.T)
        return np.exp(-0.5 * np.maximum(d2, 0.0) / self.sigma**2) @ self.weights


def direction(alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Unit vectors [cos α cos β, sin β, sin α cos β] (seed Eq 4.3), shape (N, 3)."""
    cb = np.cos(beta)
    return np.stack([np.cos(alpha) * cb, np.sin(beta), np.sin(alpha) * cb], axis=1)


def angles_of(d: Sequence[float]) -> tuple[float, float]:
    """Polar angles (α, β) of a direction vector — the inverse of :func:`direction`."""
    x, y, z = np.asarray(d, float) / np.linalg.norm(d)
    return float(np.arctan2(z, x)), float(np.arcsin(np.clip(y, -1, 1)))


@dataclass(frozen=True)
class LinearField:
    """Ψ(v)·φ(v): the displacement of a linear AU at τ = 1.

    ``mirror``: the field is defined on the subject's left half (x ≥ 0) and mirrored to the
    right (an extension for hand-authored symmetric AUs; the x component fades smoothly to 0
    at the midline so the two halves meet without a crease).
    """

    alpha: Cubic
    beta: Cubic
    gaussians: tuple[Gaussian, ...]
    mirror: bool = False
    rbf: Rbf | None = None  # optional smooth residual (extension, fitted "rich" family)

    @classmethod
    def from_json(cls, d: Mapping) -> LinearField:
        psi = d.get("psi", {})
        if "direction" in psi:
            a, b = angles_of(psi["direction"])
            alpha, beta = Cubic.from_json({"c": a}), Cubic.from_json({"c": b})
        else:
            alpha, beta = Cubic.from_json(psi.get("alpha")), Cubic.from_json(psi.get("beta"))
        gs = tuple(Gaussian.from_json(g) for g in d.get("phi", []))
        if not gs:
            raise ValueError("phi needs at least one Gaussian")
        rbf = None if d.get("rbf") is None else Rbf.from_json(d["rbf"])
        return cls(alpha, beta, gs, bool(d.get("mirror", False)), rbf)

    def to_json(self) -> dict:
        out = {"psi": {"alpha": self.alpha.to_json(), "beta": self.beta.to_json()},
               "phi": [g.to_json() for g in self.gaussians]}
        if self.mirror:
            out["mirror"] = True
        if self.rbf is not None:
            out["rbf"] = self.rbf.to_json()
        return out

    def psi(self, u: np.ndarray) -> np.ndarray:
        """Unit directions at ``u`` (N, 3)."""
        return direction(self.alpha(u), self.beta(u))

    def phi(self, u: np.ndarray) -> np.ndarray:
        """Densities at ``u``, shape (N,)."""
        return sum(g(u) for g in self.gaussians)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Displacements at τ = 1 for points ``u`` (N, 3) in field coordinates."""
        if not self.mirror:
            d = self.psi(u) * self.phi(u)[:, None]
            return d if self.rbf is None else d + self.rbf(u)
        m = u.copy()
        m[:, 0] = np.abs(m[:, 0])
        d = self.psi(m) * self.phi(m)[:, None]
        d[:, 0] *= np.tanh(u[:, 0] / 0.3)
        return d if self.rbf is None else d + self.rbf(u)


@dataclass(frozen=True)
class SplitField:
    """A sub-object AU's pair of fields, chosen by the side of a split surface (seed §4.3.2:
    the plane through the mouth corners; ``split`` names which surface, default ``mouth``)."""

    upper: LinearField | None
    lower: LinearField | None
    split: str = "mouth"


@dataclass(frozen=True)
class Split:
    """A plane through ``point`` with ``normal`` (toward the upper half), optionally bent by a
    ``profile``: offsets along the normal as a piecewise-linear function of |x| (cm), so the
    surface can follow a curved lip line or lid fissure (an extension of the seed's plane).

    ``soft`` = (x_in, x_out, k): outside the opening — |x| < x_in or |x| > x_out (the eye or
    mouth corners) — the split is not a sharp cut but a blend of the two fields over a band
    whose half-width grows by k cm per cm from the corner, so the skin stays continuous there.
    Across the opening itself it is sharp, as in the seed.
    """

    point: np.ndarray
    normal: np.ndarray
    profile: np.ndarray | None = None  # shape (M, 2): |x|, offset; sorted by |x|
    soft: tuple[float, float, float] | None = None

    @classmethod
    def from_json(cls, d: Mapping) -> Split:
        n = np.asarray(d["normal"], float)
        prof = d.get("profile")
        if prof is not None:
            prof = np.asarray(prof, float).reshape(-1, 2)
            prof = prof[np.argsort(prof[:, 0])]
        soft = d.get("soft")
        return cls(np.asarray(d["point"], float), n / np.linalg.norm(n), prof,
                   None if soft is None else tuple(float(x) for x in soft))

    def signed(self, v: np.ndarray) -> np.ndarray:
        """Signed distance (along the normal) of points (N, 3) above the split surface."""
        s = (v - self.point) @ self.normal
        if self.profile is not None:
            s = s - np.interp(np.abs(v[:, 0] - self.point[0]), *self.profile.T)
        return s

    def upper_weight(self, v: np.ndarray) -> np.ndarray:
        """Weight of the upper field for points (N, 3), shape (N,), in [0, 1]: 1 above the
        split, 0 below, blended across the soft band outside the opening."""
        s = self.signed(v)
        ax = np.abs(v[:, 0] - self.point[0])
        hard = (s > 0).astype(float)
        if self.soft is None:
            return hard
        x_in, x_out, k = self.soft
        width = k * np.maximum(np.maximum(ax - x_out, x_in - ax), 0.0)
        t = np.clip(0.5 + 0.5 * s / np.maximum(width, 1e-9), 0.0, 1.0)
        return np.where(width > 1e-6, t * t * (3 - 2 * t), hard)

    def surface_weight(self, v: np.ndarray, faces: np.ndarray, band: float = 0.6,
                       blend: float = 0.0) -> np.ndarray:
        """:meth:`upper_weight` of a mesh's vertices, decided anew within ``band`` cm of the
        split inside the opening: each vertex goes to the side it is nearer to along the
        mesh. A lip's inner face curls behind the other lip and closed lips touch along a
        line, so vertices a few millimetres past any smooth surface still belong to the lip
        their surface runs to (else the upper lip's inner face hangs down with the lower).
        Shapes generated on a mesh use it; the FieldRig keeps the seed's rule (a field over
        space: the same point moves alike on any mesh). ``blend`` (cm): where the two sides
        are within this of equally near — skin the split crosses where the opening ends, at
        the mouth or eye corners — the weight blends between them instead of jumping."""
        w = self.upper_weight(v)
        amb = (np.abs(self.signed(v)) < band) & ((w == 0.0) | (w == 1.0))
        sides = [np.flatnonzero(~amb & (w > 0.5)), np.flatnonzero(~amb & (w <= 0.5))]
        if not amb.any() or not all(len(x) for x in sides):
            return w
        e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        g = coo_matrix((np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1) + 1e-9,
                        (e[:, 0], e[:, 1])), shape=(len(v), len(v))).tocsr()
        d_up, d_lo = (dijkstra(g, directed=False, indices=x, min_only=True) for x in sides)
        w = w.copy()
        if blend > 0:
            t = np.clip(0.5 + 0.5 * (d_lo - d_up) / blend, 0.0, 1.0)
            w[amb] = (t * t * (3 - 2 * t))[amb]
            return w
        w[amb & (d_up < d_lo)] = 1.0
        w[amb & (d_lo < d_up)] = 0.0
        return w


@dataclass(frozen=True)
class RotationAU:
    """A non-linear AU: rotation by τ·angle about ``axis`` through ``pivot`` (seed Eq 4.2).

    ``pivot`` is a point (cm) or ``"object"`` (the object's own pivot, e.g. an eyeball centre).
    ``falloff`` (top, bottom) in y: weight 1 above ``top``, smoothstep to 0 at ``bottom``.
    ``vector`` instead of an axis makes it a translation (AU57/58).
    """

    axis: np.ndarray | None
    angle: float  # radians at τ = 1
    pivot: np.ndarray | str
    falloff: tuple[float, float] | None
    vector: np.ndarray | None = None

    @classmethod
    def from_json(cls, d: Mapping) -> RotationAU:
        piv = d.get("pivot", "object")
        fo = d.get("falloff")
        return cls(
            None if "axis" not in d else np.asarray(d["axis"], float) / np.linalg.norm(d["axis"]),
            np.radians(float(d.get("angle", 0.0))),
            piv if isinstance(piv, str) else np.asarray(piv, float),
            None if fo is None else (float(fo["top"]), float(fo["bottom"])),
            None if "vector" not in d else np.asarray(d["vector"], float),
        )

    def weight(self, v: np.ndarray) -> np.ndarray:
        """φ: the smoothed step from 1 (head) to 0 (neck base), shape ``v.shape[:-1]``."""
        if self.falloff is None:
            return np.ones(v.shape[:-1], v.dtype)
        top, bottom = self.falloff
        t = np.clip((v[..., 1] - bottom) / (top - bottom), 0.0, 1.0)
        return t * t * (3 - 2 * t)

    def apply(self, v: np.ndarray, tau: float | np.ndarray,
              pivot: np.ndarray | None) -> np.ndarray:
        """Move points ``v`` (N, 3) for intensity ``tau`` (may be negative for opposites);
        or many frames at once: ``v`` (T, N, 3) with ``tau`` (T,)."""
        tau = np.asarray(tau, v.dtype)
        w = (self.weight(v) * (tau[:, None] if tau.ndim else tau)).astype(v.dtype)
        if self.vector is not None:
            return v + w[..., None] * self.vector
        p = pivot if isinstance(self.pivot, str) else self.pivot
        return rotate(v, self.axis, self.angle * w, p)


def rotate(v: np.ndarray, axis: np.ndarray, angles: np.ndarray, pivot: np.ndarray) -> np.ndarray:
    """Rotate points ``v`` (..., 3) about ``axis`` through ``pivot`` by per-point ``angles``
    (shape ``v.shape[:-1]``; Rodrigues' formula)."""
    dt = v.dtype if v.dtype == np.float32 else np.float64
    k = np.asarray(axis, dt)
    p = np.asarray(pivot, dt)
    r = v - p
    ang = np.asarray(angles, dt)
    c, s = np.cos(ang)[..., None], np.sin(ang)[..., None]
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    kxr = np.stack([k[1] * z - k[2] * y, k[2] * x - k[0] * z, k[0] * y - k[1] * x], axis=-1)
    return p + r * c + kxr * s + k * (r @ k)[..., None] * (1 - c)


# --- parameter files ---------------------------------------------------------------------------


@dataclass(frozen=True)
class FieldSet:
    """Parsed parameters of every AU: what a ``fields.json`` holds."""

    origin: np.ndarray  # field coordinates u = (v − origin) / scale
    scale: float
    splits: dict[str, Split]  # named split surfaces (head coordinates); "mouth" is the seed's
    linear: dict[str, dict[str, LinearField | SplitField]]  # AU → category → field
    rotations: dict[str, tuple[RotationAU, tuple[str, ...]]]  # AU → (rotation, categories)
    mixers: dict[str, str]
    source: str = "<memory>"
    #: frame rotation R (3, 3): u = R·(v − origin)/scale; None = identity
    rotation: np.ndarray | None = None

    @property
    def aus(self) -> tuple[str, ...]:
        codes = set(self.linear) | set(self.rotations)
        return tuple(c for c in AU_CATALOGUE if c in codes)

    def to_u(self, v: np.ndarray) -> np.ndarray:
        u = (np.asarray(v, float) - self.origin) / self.scale
        return u if self.rotation is None else u @ self.rotation.T

    def to_head(self, du: np.ndarray) -> np.ndarray:
        """Field-frame displacements (N, 3) → head displacements (cm): scale·Rᵀ·Δu."""
        d = du if self.rotation is None else du @ self.rotation
        return d * self.scale


def _scaled(f: LinearField | SplitField | None, gain: float, spread: float):
    """``f`` with every Gaussian's η × ``gain`` and σ × ``spread`` (means kept) and its RBF
    residual × ``gain``: an AU field's calibration (``"calibration": {"gain", "spread"}``)."""
    if f is None:
        return None
    if isinstance(f, SplitField):
        return replace(f, upper=_scaled(f.upper, gain, spread),
                       lower=_scaled(f.lower, gain, spread))
    gs = tuple(replace(g, eta=g.eta * gain, B=g.B / spread**2) for g in f.gaussians)
    rbf = None if f.rbf is None else replace(f.rbf, weights=f.rbf.weights * gain)
    return replace(f, gaussians=gs, rbf=rbf)


def _calibration(spec: Mapping) -> tuple[float, float]:
    cal = spec.get("calibration", {})
    gain, spread = float(cal.get("gain", 1.0)), float(cal.get("spread", 1.0))
    if not (0.0 <= gain <= 10.0 and 0.1 <= spread <= 10.0):
        raise ValueError(f"calibration gain={gain} must be in [0, 10] and spread={spread} in "
                         "[0.1, 10]")
    return gain, spread


def _field_from_json(d: Mapping, splits: Mapping[str, Split]) -> LinearField | SplitField:
    if "upper" in d or "lower" in d:
        up, lo = d.get("upper"), d.get("lower")
        name = d.get("split", "mouth")
        if name not in splits:
            raise ValueError(f"split {name!r} is not defined; defined: {sorted(splits)}")
        return SplitField(
            None if up is None else LinearField.from_json(up),
            None if lo is None else LinearField.from_json(lo),
            name,
        )
    return LinearField.from_json(d)


def parse_fields(data: Mapping, *, source: str = "<memory>") -> FieldSet:
    """Validate and parse a fields document; errors name ``source`` and the JSON path."""
    if data.get("format") != "mimika-fields":
        raise DataError(f"{source}: not a mimika fields file (expected \"format\": "
                        f"\"mimika-fields\")")
    if int(data.get("version", 0)) != 1:
        raise DataError(f"{source}: fields version {data.get('version')!r} is not supported "
                        f"(this mimika reads version 1)")
    linear: dict[str, dict] = {}
    rotations: dict[str, tuple] = {}
    mixers: dict[str, str] = {}
    try:
        raw = dict(data.get("splits", {}))
        raw.setdefault("mouth", data.get("split", {"point": [0, 0, 0], "normal": [0, 1, 0]}))
        splits = {name: Split.from_json(d) for name, d in raw.items()}
    except (KeyError, ValueError, TypeError) as e:
        raise DataError(f"{source}: splits: {e}") from None
    for key, spec in data.get("aus", {}).items():
        where = f"{source}: aus.{key}"
        try:
            code = parse_au(key)
        except ParameterError as e:
            raise DataError(f"{where}: {e}") from None
        try:
            kind = spec.get("kind", "linear")
            if kind == "linear":
                gain, spread = _calibration(spec)
                linear[code] = {cat: _scaled(_field_from_json(f, splits), gain, spread)
                                for cat, f in spec["objects"].items()}
            elif kind in ("rotation", "translation"):
                rotations[code] = (RotationAU.from_json(spec), tuple(spec["objects"]))
            else:
                raise ValueError(f"kind {kind!r} must be linear, rotation or translation")
            mixer = spec.get("mixer", "additive" if kind == "linear" else "successive")
            if mixer not in MIXERS:
                raise ValueError(f"mixer {mixer!r} must be one of {MIXERS}")
            mixers[code] = mixer
        except (KeyError, ValueError, TypeError) as e:
            msg = f"missing key {e}" if isinstance(e, KeyError) else str(e)
            raise DataError(f"{where}: {msg}") from None
    frame = data.get("frame", {})
    return FieldSet(
        origin=np.asarray(frame.get("origin", [0, 0, 0]), float),
        scale=float(frame.get("scale", 1.0)),
        rotation=_frame_rotation(frame, source),
        splits=splits,
        linear=linear,
        rotations=rotations,
        mixers=mixers,
        source=source,
    )


def _frame_rotation(frame: Mapping, source: str) -> np.ndarray | None:
    """``frame.rotation`` (3×3, proper orthonormal) or None when absent."""
    if frame.get("rotation") is None:
        return None
    try:
        r = np.asarray(frame["rotation"], float).reshape(3, 3)
    except (ValueError, TypeError):
        raise DataError(f"{source}: frame.rotation must be a 3x3 matrix") from None
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-4) or np.linalg.det(r) < 0:
        raise DataError(f"{source}: frame.rotation must be a rotation matrix (orthonormal, "
                        f"det +1)")
    return r


def load_fields(path: str | Path | None = None) -> FieldSet:
    """Read a fields file; ``None`` loads the built-in head's fields shipped with mimika."""
    if path is None:
        res = resources.files("mimika.face").joinpath("data/builtin_fields.json")
        return parse_fields(json.loads(res.read_text("utf-8")), source="builtin_fields.json")
    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except OSError as e:
        raise DataError(f"cannot read fields file {p}: {e.strerror}") from None
    return parse_fields(loads_json(text, str(p)), source=str(p))  # hostile JSON: DataError


# --- the rig -----------------------------------------------------------------------------------


class FieldRig(Rig):
    """Seed 002's AU model on any head.

    Parameters
    ----------
    head : Head
    fields : FieldSet
    mixers : dict, optional
        Per-AU override of the mixer (``"additive"`` or ``"successive"``).
    order : sequence of AU codes, optional
        Order of successive AUs (default: linear AUs, then eye rotations, then head motion —
        seed 002's default: each object's own AUs first, whole-head AUs last).
    keep_lids : bool
        Skin lying on an eyeball slides over it: after the additive AUs, lid vertices a
        field moved toward an eye's centre are pushed back to their rest distance (default).

    Additive AUs are evaluated on the rest mesh and summed (order-free); successive AUs are
    then applied one after another to the already deformed mesh, in ``order``.
    """

    def __init__(
        self,
        head: Head,
        fields: FieldSet,
        *,
        mixers: Mapping[str, str] | None = None,
        order: Sequence[str] | None = None,
        keep_lids: bool = True,
    ) -> None:
        self.head = head
        self.fields = fields
        self.mixers = dict(fields.mixers)
        for code, m in (mixers or {}).items():
            c = parse_au(code)
            if m not in MIXERS:
                raise ParameterError(f"mixer for {c} is {m!r}; use one of {', '.join(MIXERS)}")
            if c not in self.mixers:
                raise ParameterError(f"{c} is not modelled by these fields")
            if c in fields.rotations and m == "additive":
                raise ParameterError(f"{c} is a rotation: it can only be mixed successively")
            self.mixers[c] = m
        self.order = self._order(order)
        #: skin on the eyeballs never sinks into them (:meth:`_keep_lids_on_eyes`)
        self.keep_lids = keep_lids

    # -- what it models
    @property
    def supported(self) -> tuple[str, ...]:
        out: list[str] = []
        for c in self.fields.aus:
            out.append(c)
            if AU_CATALOGUE[c].sided:
                out += [c + "L", c + "R"]
        return tuple(out)

    def _order(self, order: Sequence[str] | None) -> tuple[str, ...]:
        default = [c for c in self.fields.aus if c in self.fields.linear]
        default += [c for c in self.fields.aus if c in self.fields.rotations and
                    AU_CATALOGUE[c].group == "eyes"]
        default += [c for c in self.fields.aus if c in self.fields.rotations and
                    AU_CATALOGUE[c].group != "eyes"]
        if order is None:
            return tuple(default)
        given = [parse_au(c) for c in order]
        unknown = [c for c in given if c not in default]
        if unknown:
            raise ParameterError(f"order names AUs these fields do not model: {unknown}")
        return tuple(given + [c for c in default if c not in given])

    # -- cached per-object data (derived from the rest mesh; read-only)
    @cached_property
    def _upper(self) -> dict[tuple[str, str], np.ndarray]:
        """Per (split, object): weight of the upper field for each vertex, from the side it
        starts on (seed §4.3.2). Rigid objects (eyes, teeth) go whole, by their centroid."""
        out = {}
        for name, split in self.fields.splits.items():
            for o in self.head.objects:
                if o.category == "face":
                    w = split.upper_weight(o.vertices)
                else:
                    centre = o.vertices.mean(0, keepdims=True)
                    w = np.full(o.n_vertices, float(split.upper_weight(centre)[0] > 0.5))
                w.setflags(write=False)
                out[name, o.name] = w
        return out

    def _side_mask(self, v: np.ndarray, side: str | None) -> np.ndarray | None:
        if side is None:
            return None
        x = (v[:, 0] - self.fields.origin[0]) / SIDE_SOFTNESS
        return 0.5 * (1 + np.tanh(x if side == "L" else -x))

    def field_at(self, code: str, name: str, v: np.ndarray) -> np.ndarray:
        """Displacement at τ = 1 of linear AU ``code`` for points ``v`` (N, 3) of object
        ``name`` (its category selects the field; its rest sides select sub-object halves)."""
        obj = self.head[name]
        f = self.fields.linear[code].get(obj.category)
        out = np.zeros((v.shape[0], 3))
        if f is None:
            return out
        u = self.fields.to_u(v)
        if isinstance(f, LinearField):
            out[:] = f(u)
        else:
            w = self._upper[f.split, name]
            for half, wh in ((f.upper, w), (f.lower, 1.0 - w)):
                sel = wh > 0
                if half is not None and sel.any():
                    out[sel] += half(u[sel]) * wh[sel, None]
        return self.fields.to_head(out)

    @cached_property
    def _basis(self) -> dict[str, dict[str, np.ndarray]]:
        """Per linear AU and object: Δ at τ = 1 on the rest mesh (float32, read-only)."""
        out: dict[str, dict[str, np.ndarray]] = {}
        for code in self.fields.linear:
            per = {}
            for o in self.head.objects:
                if o.category in self.fields.linear[code]:
                    d = self.field_at(code, o.name, o.vertices).astype(np.float32)
                    d.setflags(write=False)
                    per[o.name] = d
            out[code] = per
        return out

    @cached_property
    def _additive(self) -> dict[str, np.ndarray | None]:
        """Per object: matrix (R, 3·N) float32 — the displacement at τ = 1 of every additive
        AU, one row per side for sided AUs (left mask, right mask; they sum to the bilateral
        field), one row otherwise, in :attr:`_rows` order; ``None`` for objects none moves."""
        out: dict[str, np.ndarray | None] = {}
        for o in self.head.objects:
            rows = []
            for code, sided in self._rows:
                d = self._basis[code].get(o.name)
                if d is None:
                    d = np.zeros((o.n_vertices, 3), np.float32)
                if sided:
                    ml = self._side_mask(o.vertices, "L")[:, None]
                    rows += [d * ml, d * (1 - ml)]
                else:
                    rows.append(d)
            if not rows or not np.any(rows):
                out[o.name] = None
                continue
            mat = np.ascontiguousarray(np.stack(rows).reshape(len(rows), -1), np.float32)
            mat.setflags(write=False)
            out[o.name] = mat
        return out

    @cached_property
    def _rows(self) -> tuple[tuple[str, bool], ...]:
        """The additive AUs in matrix-row order, with whether each has a left and right row."""
        return tuple((c, AU_CATALOGUE[c].sided) for c in self.fields.aus
                     if c in self.fields.linear and self.mixers[c] == "additive")

    def _row_values(self, values: np.ndarray, chans: Sequence[str]) -> np.ndarray:
        """Frames (T, K) over ``chans`` → row weights (T, R): per side, bilateral plus
        one-sided intensity, capped at 1 (``AU12=1, AU12L=.5`` → left 1, right 1)."""
        col = {c: j for j, c in enumerate(chans)}
        zero = np.zeros(len(values), np.float32)
        out = []
        for code, sided in self._rows:
            bil = values[:, col[code]] if code in col else zero
            if sided:
                for side in "LR":
                    one = values[:, col[code + side]] if code + side in col else zero
                    out.append(np.minimum(bil + one, 1.0))
            else:
                out.append(np.minimum(bil, 1.0))
        return np.stack(out, 1) if out else np.zeros((len(values), 0), np.float32)

    def _successive(self, pos: Positions, sides: Mapping[str, tuple[float, float]]) -> None:
        """Apply the successive AUs in :attr:`order` to ``pos`` in place."""
        for code in self.order:
            if code not in sides or self.mixers[code] != "successive":
                continue
            tl, tr = sides[code]
            if code in self.fields.linear:
                for name in self._basis[code]:
                    d = self.field_at(code, name, pos[name])
                    pos[name] += self._sided(d, self.head[name].vertices, tl, tr).astype(
                        np.float32)
            else:
                rot, cats = self.fields.rotations[code]
                for o in self.head.objects:
                    if o.category in cats:
                        pos[o.name] = rot.apply(pos[o.name], tl, o.pivot).astype(np.float32)

    @cached_property
    def _lids(self) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
        """Skin that lies on an eyeball (within :data:`LID_BAND` cm of its sphere at rest):
        (object, vertex ids, eye centre, rest distance from it) per face object and eye."""
        out = []
        eyes = [o for o in self.head.objects if o.category == "eyes" and o.pivot is not None]
        for o in self.head.objects:
            if o.category != "face" or self._additive.get(o.name) is None:
                continue
            for e in eyes:
                radius = float(np.median(np.linalg.norm(e.vertices - e.pivot, axis=1)))
                d0 = np.linalg.norm(o.vertices - e.pivot, axis=1)
                ids = np.flatnonzero(d0 < radius + LID_BAND)
                if len(ids):
                    out.append((o.name, ids, e.pivot.astype(np.float32), d0[ids]))
        return out

    def _keep_lids_on_eyes(self, out: dict[str, np.ndarray]) -> None:
        """Lids slide over the eyeballs: skin that a field moved closer to an eye's centre
        than it rests is pushed back out to its rest distance (tangential motion kept)."""
        for name, ids, centre, d0 in self._lids:
            p = out[name][:, ids] - centre  # (T, n, 3)
            d = np.linalg.norm(p, axis=2)
            inside = d < d0
            if inside.any():
                scale = np.where(inside, d0 / np.maximum(d, 1e-6), 1.0)
                out[name][:, ids] = centre + p * scale[..., None]

    # -- deformation
    def deform(self, aus: Mapping[str, float]) -> Positions:
        vals = self.check(aus)
        chans = list(vals)
        row = np.array([[vals[c] for c in chans]], np.float32)
        pos = {name: p[0] for name, p in self.deform_batch(row, chans, check=False).items()}
        return pos

    def deform_batch(self, values: np.ndarray, channels: Sequence[str], *,
                     check: bool = True) -> dict[str, np.ndarray]:
        """Vectorised :meth:`deform` for frames ``values`` (T, K) → {object: (T, N, 3)}: one
        matrix product for the additive AUs, then the successive ones frame by frame (only
        in frames where one is active)."""
        values = np.asarray(values, np.float32)
        if values.ndim != 2 or values.shape[1] != len(channels):
            raise ParameterError(f"values must have shape (frames, {len(channels)}), "
                                 f"got {values.shape}")
        chans = [parse_au(c) for c in channels]
        if check:
            self.check(dict.fromkeys(chans, 0.0))
            if values.size and (values.min() < 0 or values.max() > 1):
                raise ParameterError("AU values must be in [0, 1]")
        weights = self._row_values(values, chans)
        out = {}
        for o in self.head.objects:
            mat = self._additive[o.name]
            if mat is None:
                pos = np.broadcast_to(o.vertices.ravel(), (len(values), o.n_vertices * 3)).copy()
            else:
                pos = weights @ mat
                pos += o.vertices.ravel()
            out[o.name] = pos.reshape(len(values), o.n_vertices, 3)
        if self.keep_lids:
            self._keep_lids_on_eyes(out)
        succ = [j for j, c in enumerate(chans) if self.mixers[c[:4]] == "successive"]
        if any(chans[j] in self.fields.linear for j in succ):  # rare: per frame
            for t in np.nonzero(np.any(values[:, succ] != 0, axis=1))[0]:
                frame = {chans[j]: float(values[t, j]) for j in succ if values[t, j] != 0}
                pos = {name: out[name][t] for name in out}
                self._successive(pos, split_sides(frame))
                for name in out:
                    out[name][t] = pos[name]
            return out
        col = {chans[j]: j for j in succ}
        for code in self.order:  # rotations: each over all the frames where it is active
            if code not in col:
                continue
            tau = values[:, col[code]]
            active = np.nonzero(tau)[0]
            if not len(active):
                continue
            rot, cats = self.fields.rotations[code]
            for o in self.head.objects:
                if o.category in cats:
                    out[o.name][active] = rot.apply(out[o.name][active], tau[active], o.pivot)
        return out

    def _sided(self, d: np.ndarray, rest: np.ndarray, tl: float, tr: float) -> np.ndarray:
        if tl == tr:
            return d * tl
        ml = self._side_mask(rest, "L")
        return d * (tl * ml + tr * (1 - ml))[:, None]


def load_field_rig(head: Head, path: str | Path | None = None, **kwargs) -> FieldRig:
    """A :class:`FieldRig` on ``head`` with fields from ``path`` (default: built-in fields)."""
    return FieldRig(head, load_fields(path), **kwargs)
