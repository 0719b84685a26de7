"""Fit seed 002's AU fields to measured (scanned) shapes and carry them to other faces.

Seed 002 §4.2 fits, per AU, a direction field Ψ (polar angles α, β: cubic polynomials of the
position, Eq 4.3–4.5) and a density φ (one Gaussian, two for bilateral AUs, Eq 4.6–4.7) to the
displacements neutral → AU at full intensity, with Nelder–Mead, Ψ first then φ:

    E_Ψ = Σᵢ |Δvᵢ − |Δvᵢ|·Ψ(vᵢ)|        (Eq 4.8)
    E_φ = Σᵢ (|Δvᵢ| − φ(vᵢ))²            (Eq 4.9)

Here the measurements are the ICT Face Model's light-stage shapes, composed per AU by the
:class:`~mimika.face.blendshape.BlendshapeRig` at τ = 1 (so derived AUs such as AU25/26 use the
same composition as the ICT head). Two function families:

``seed``
    the seed's Ψ·φ, fitted as the seed does (Nelder–Mead, E_Ψ then E_φ), from least-squares
    initial values (angles by weighted linear least squares, Gaussians from weighted moments).
``rich``
    the seed's fit plus a smooth vector residual Σₖ wₖ·exp(−|u−cₖ|²/2σ²) on up to
    ``rbf_centers`` centres (farthest-point samples of the moving vertices), solved by ridge
    least squares and stored in the fields file (``rbf`` key, see docs/rigs.md).

Accuracy (seed Table 4.3: n, d, d_max, e, e_max, in mm) is measured through a
:class:`~mimika.face.field.FieldRig` built from the written document, on held-out moving
vertices (a fixed random half never used in fitting).

:func:`transfer_fields` carries a fitted document to another head: a similarity transform
(Umeyama) of the 68 Multi-PIE landmarks goes into the file's ``frame`` (origin, scale,
rotation); split surfaces are rebuilt from the target's own landmarks and head rotations use
its anchors.
"""

from __future__ import annotations

import csv
import io
import json
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from mimika.errors import DataError, ParameterError
from mimika.face.field import (
    Cubic,
    FieldRig,
    Gaussian,
    LinearField,
    Rbf,
    Split,
    parse_fields,
)
from mimika.face.head import Head
from mimika.facs import AU_CATALOGUE, parse_au

log = logging.getLogger(__name__)

__all__ = [
    "FAMILIES",
    "SUB_OBJECT",
    "AuAccuracy",
    "FitOptions",
    "FitResult",
    "eye_split",
    "fit_field",
    "fit_ict",
    "fit_phi",
    "fit_psi",
    "landmark_agreement",
    "load_fitted_rig",
    "mouth_split",
    "refine_mouth_split",
    "report_csv",
    "report_markdown",
    "similarity_transform",
    "transfer_fields",
]

FAMILIES = ("seed", "rich")
#: seed §4.3.2: AUs whose mesh is split by the surface through the mouth corners
SUB_OBJECT = ("AU10", "AU16", "AU18", "AU22", "AU25", "AU27", "AU28")
#: lid AUs split by the eye fissure in the rich family (upper and lower lid move apart)
LID_AUS = ("AU05", "AU07", "AU41", "AU42", "AU43", "AU44", "AU45", "AU46")
#: jaw AUs also split by the mouth in the rich family (the ICT jaw shapes part the lips)
JAW_AUS = ("AU26", "AU29", "AU30")
#: the ICT "face" vertex range (README: face 0–9408) inside the ``skin`` object
FACE_RANGE = (0, 9409)
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class FitOptions:
    """Budgets and settings of a fit (all fixed, so a fit is deterministic).

    moving_fraction, moving_min_cm : a vertex "moves" (Table 4.3's n) when |Δv| ≥
        max(moving_min_cm, moving_fraction·d_max).
    holdout : fraction of the moving vertices kept out of fitting and used for the report.
    max_vertices : moving vertices per field used by the optimisers (sub-sampled).
    still_vertices : still vertices near the motion added with target 0 (keep φ from leaking).
    psi_evals, phi_evals : Nelder–Mead function-evaluation caps for Ψ (38 free parameters:
        A1, A3 enter only through their symmetric parts) and φ (10 per Gaussian).
    sigma_min_cm : lower bound of every Gaussian's standard deviation, in every direction
        (Σ = σ_min²·I + LLᵀ), so φ does not collapse across the surface it was fitted on.
    rbf_centers, rbf_ridge : the ``rich`` family's residual: centres per field, ridge weight.
    lid_split : lid AUs (:data:`LID_AUS`) become sub-object AUs split by the eye fissure
        (:func:`eye_split`) and jaw AUs (:data:`JAW_AUS`) split by the mouth; default: on for
        ``rich``, off for ``seed`` (the seed splits the mouth for its seven AUs only).
    """

    family: str = "seed"
    seed: int = 0
    moving_fraction: float = 0.05
    moving_min_cm: float = 0.01
    holdout: float = 0.5
    max_vertices: int = 1500
    still_vertices: int = 500
    psi_evals: int = 6000
    phi_evals: int = 3000
    sigma_min_cm: float = 0.4
    rbf_centers: int = 240
    rbf_ridge: float = 1e-4
    lid_split: bool | None = None

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            raise ParameterError(f"family {self.family!r} must be one of {', '.join(FAMILIES)}")
        if self.lid_split is None:
            object.__setattr__(self, "lid_split", self.family == "rich")
        if not 0.0 <= self.holdout < 1.0:
            raise ParameterError(f"holdout={self.holdout} must be in [0, 1)")


# --- polynomial features ------------------------------------------------------------------------

_SYM = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def _quad(u: np.ndarray) -> np.ndarray:
    """Quadratic features (N, 6) with u·A·u = _quad(u) @ [a00, a11, a22, a01, a02, a12]."""
    x, y, z = u.T
    return np.stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z], axis=1)


def _sym(a: np.ndarray) -> np.ndarray:
    m = np.zeros((3, 3))
    for k, (i, j) in enumerate(_SYM):
        m[i, j] = m[j, i] = a[k]
    return m


def _cubic_from(theta: np.ndarray) -> Cubic:
    """19 parameters [a1 (6), a2 (3), a3 (6), a4 (3), c] → :class:`Cubic`."""
    return Cubic(_sym(theta[0:6]), theta[6:9].copy(), _sym(theta[9:15]), theta[15:18].copy(),
                 float(theta[18]))


def _cubic_eval(theta: np.ndarray, q: np.ndarray, u: np.ndarray) -> np.ndarray:
    return (q @ theta[0:6]) * (u @ theta[6:9]) + q @ theta[9:15] + u @ theta[15:18] + theta[18]


def _direction(alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    cb = np.cos(beta)
    return np.stack([np.cos(alpha) * cb, np.sin(beta), np.sin(alpha) * cb], axis=1)


def _nelder_mead(fun: Callable[[np.ndarray], float], x0: np.ndarray, step: np.ndarray | float,
                 max_evals: int) -> np.ndarray:
    """Nelder–Mead (scipy, adaptive) from ``x0`` with a fixed axis-aligned initial simplex."""
    n = len(x0)
    simplex = np.repeat(x0[None], n + 1, axis=0)
    simplex[1:] += np.diag(np.broadcast_to(np.asarray(step, float), (n,)))
    res = minimize(fun, x0, method="Nelder-Mead",
                   options={"initial_simplex": simplex, "maxfev": max_evals, "adaptive": True,
                            "xatol": 1e-7, "fatol": 1e-10})
    return res.x if res.fun <= fun(x0) else x0


# --- Ψ: Eq 4.8 ----------------------------------------------------------------------------------


def _psi_error(theta: np.ndarray, q: np.ndarray, u: np.ndarray, d: np.ndarray,
               mag: np.ndarray) -> float:
    psi = _direction(_cubic_eval(theta[:19], q, u), _cubic_eval(theta[19:], q, u))
    return float(np.linalg.norm(d - mag[:, None] * psi, axis=1).sum())


def fit_psi(u: np.ndarray, d: np.ndarray, *, max_evals: int = 6000) -> tuple[Cubic, Cubic]:
    """Fit Ψ's polar-angle cubics (α, β) to displacements ``d`` (N, 3) at points ``u`` (N, 3).

    Initial values: weighted linear least squares of the measured angles (weights |Δv|, times
    cos²β for α), with A2 fixed to each axis in turn (the product term is then linear in A1),
    keeping the best by E_Ψ; then Nelder–Mead on E_Ψ (Eq 4.8) with ``max_evals`` evaluations.
    """
    u = np.asarray(u, float)
    d = np.asarray(d, float)
    mag = np.linalg.norm(d, axis=1)
    keep = mag > 1e-12
    if keep.sum() < 3:
        raise ParameterError("fit_psi needs at least 3 displaced points")
    uu, dd, mm = u[keep], d[keep], mag[keep]
    q = _quad(uu)
    dn = dd / mm[:, None]
    beta_t = np.arcsin(np.clip(dn[:, 1], -1, 1))
    mean_dir = (dn * mm[:, None]).sum(0)
    a0 = np.arctan2(mean_dir[2], mean_dir[0])
    alpha_t = a0 + np.angle(np.exp(1j * (np.arctan2(dn[:, 2], dn[:, 0]) - a0)))
    w_b = mm / mm.sum()
    w_a = w_b * np.cos(beta_t) ** 2 + 1e-9

    def lsq(target: np.ndarray, w: np.ndarray, a2: np.ndarray) -> np.ndarray:
        lin = np.c_[q, uu, np.ones(len(uu))]
        if np.any(a2):
            lin = np.c_[q * (uu @ a2)[:, None], lin]
        sw = np.sqrt(w)[:, None]
        a = lin * sw
        reg = 1e-6 * np.trace(a.T @ a) / a.shape[1]
        sol = np.linalg.solve(a.T @ a + reg * np.eye(a.shape[1]), a.T @ (target * sw[:, 0]))
        theta = np.zeros(19)
        theta[6:9] = a2
        if np.any(a2):
            theta[0:6], sol = sol[:6], sol[6:]
        theta[9:15], theta[15:18], theta[18] = sol[:6], sol[6:9], sol[9]
        return theta

    best, best_e = None, np.inf
    for a2 in (np.zeros(3), *np.eye(3)):
        theta = np.r_[lsq(alpha_t, w_a, a2), lsq(beta_t, w_b, a2)]
        e = _psi_error(theta, q, uu, dd, mm)
        if e < best_e:
            best, best_e = theta, e
    assert best is not None
    theta = _nelder_mead(lambda t: _psi_error(t, q, uu, dd, mm), best, 0.05, max_evals)
    log.debug("fit_psi: E_psi/sum|d| %.4f (init) → %.4f", best_e / mm.sum(),
              _psi_error(theta, q, uu, dd, mm) / mm.sum())
    return _cubic_from(theta[:19]), _cubic_from(theta[19:])


# --- φ: Eq 4.9 ----------------------------------------------------------------------------------

_TRIL = np.tril_indices(3)


def _gaussians_from(theta: np.ndarray, s2min: float) -> list[Gaussian]:
    out = []
    for g in theta.reshape(-1, 10):
        lower = np.zeros((3, 3))
        lower[_TRIL] = g[4:10]
        cov = s2min * np.eye(3) + lower @ lower.T
        out.append(Gaussian(float(np.exp(g[0])), g[1:4].copy(), np.linalg.inv(cov)))
    return out


def _phi_eval(theta: np.ndarray, u: np.ndarray, s2min: float) -> np.ndarray:
    out = np.zeros(len(u))
    for g in theta.reshape(-1, 10):
        lower = np.zeros((3, 3))
        lower[_TRIL] = g[4:10]
        b = np.linalg.inv(s2min * np.eye(3) + lower @ lower.T)
        d = u - g[1:4]
        out += np.exp(g[0] - 0.5 * ((d @ b) * d).sum(1))
    return out


def fit_phi(u: np.ndarray, mag: np.ndarray, *, groups: Sequence[np.ndarray] | None = None,
            sigma_min: float = 0.1, max_evals: int = 3000) -> tuple[Gaussian, ...]:
    """Fit φ = Σ Gaussians to magnitudes ``mag`` (N,) at points ``u`` (N, 3) (Eq 4.9).

    ``groups``: one boolean mask (N,) per Gaussian for its initial values (weighted mean and
    covariance of the points in the group, weights |Δv|; η = the group's largest |Δv|); default
    one Gaussian over all points. Covariances are Σ = σ_min²·I + LLᵀ (σ_min in u units).
    """
    u = np.asarray(u, float)
    mag = np.asarray(mag, float)
    groups = [np.ones(len(u), bool)] if groups is None else list(groups)
    s2min = sigma_min**2
    theta0 = []
    for g in groups:
        w = mag[g]
        if w.sum() <= 0:
            raise ParameterError("fit_phi: a Gaussian's group has no displacement")
        p = u[g]
        m = (w[:, None] * p).sum(0) / w.sum()
        c = ((p - m).T * w) @ (p - m) / w.sum()
        evals, evecs = np.linalg.eigh(c)
        c = evecs @ np.diag(np.maximum(evals - s2min, 0.05 * s2min)) @ evecs.T
        lower = np.linalg.cholesky(c)
        theta0.append(np.r_[np.log(max(np.quantile(w, 0.95), 1e-9)), m, lower[_TRIL]])
    x0 = np.concatenate(theta0)

    # keep every mean within 2× the data's radius of its centroid: a near-constant density
    # could otherwise drift far away with a vanishing B (numerically fragile, lost in files)
    centre = u.mean(0)
    radius = 2.0 * float(np.linalg.norm(u - centre, axis=1).max()) + 1e-9
    weight = float((mag**2).sum())

    def err(t: np.ndarray) -> float:
        far = np.linalg.norm(t.reshape(-1, 10)[:, 1:4] - centre, axis=1) / radius - 1.0
        return float(((mag - _phi_eval(t, u, s2min)) ** 2).sum()
                     + weight * (np.maximum(far, 0.0) ** 2).sum())

    scale = np.sqrt(np.diag(np.cov(u.T))).mean() if len(u) > 3 else 1.0
    step = np.tile(np.r_[0.2, np.full(3, 0.1 * scale), np.full(6, 0.1 * scale)], len(groups))
    theta = _nelder_mead(err, x0, step, max_evals)
    log.debug("fit_phi: E_phi %.4g (init) → %.4g", err(x0), err(theta))
    return tuple(_gaussians_from(theta, s2min))


# --- the rich family's residual -----------------------------------------------------------------


def _farthest_points(p: np.ndarray, k: int, first: int) -> np.ndarray:
    """Indices of ``k`` farthest-point samples of ``p`` (N, 3), starting at ``first``."""
    k = min(k, len(p))
    idx = np.empty(k, np.int64)
    idx[0] = first
    dist = np.linalg.norm(p - p[first], axis=1)
    for i in range(1, k):
        idx[i] = int(np.argmax(dist))
        dist = np.minimum(dist, np.linalg.norm(p - p[idx[i]], axis=1))
    return idx


def fit_rbf(u: np.ndarray, r: np.ndarray, moving: np.ndarray, *, centers: int = 160,
            ridge: float = 1e-4) -> Rbf | None:
    """Ridge least-squares Gaussian RBF residual for residuals ``r`` (N, 3) at ``u`` (N, 3).

    Centres are farthest-point samples of the ``moving`` points (mask (N,)); σ = the mean
    distance from a centre to its nearest other centre.
    """
    pm = u[moving]
    if len(pm) < 4:
        return None
    first = int(np.argmax(np.linalg.norm(r[moving], axis=1)))
    c = pm[_farthest_points(pm, centers, first)]
    dc = np.linalg.norm(c[:, None] - c[None], axis=2)
    np.fill_diagonal(dc, np.inf)
    sigma = float(np.mean(dc.min(1)))
    k = np.exp(-0.5 * ((u[:, None] - c[None]) ** 2).sum(-1) / sigma**2)
    a = k.T @ k
    lam = ridge * np.trace(a) / len(c)
    w = np.linalg.solve(a + lam * np.eye(len(c)), k.T @ r)
    return Rbf(c, w, sigma)


def fit_field(u: np.ndarray, d: np.ndarray, moving: np.ndarray | None = None, *,
              bilateral: bool = False, family: str = "seed", sigma_min: float = 0.1,
              psi_evals: int = 6000, phi_evals: int = 3000, rbf_centers: int = 160,
              rbf_ridge: float = 1e-4) -> LinearField:
    """Fit one :class:`LinearField` to displacements ``d`` (N, 3) at ``u`` (N, 3) (field units).

    ``moving`` (N,) marks the displaced points (Ψ is fitted on these; φ and the residual on
    all points, the still ones with target 0). ``bilateral``: two Gaussians, initialised on
    x ≥ 0 and x < 0.
    """
    u = np.asarray(u, float)
    d = np.asarray(d, float)
    mag = np.linalg.norm(d, axis=1)
    moving = mag > 0 if moving is None else np.asarray(moving, bool)
    alpha, beta = fit_psi(u[moving], d[moving], max_evals=psi_evals)
    groups = None
    if bilateral:
        left, right = moving & (u[:, 0] >= 0), moving & (u[:, 0] < 0)
        if left.sum() >= 4 and right.sum() >= 4:
            groups = [left, right]
    if groups is None:
        groups = [moving]
    gs = fit_phi(u, mag, groups=groups, sigma_min=sigma_min, max_evals=phi_evals)
    f = LinearField(alpha, beta, gs)
    if family == "rich":
        rbf = fit_rbf(u, d - f(u), moving, centers=rbf_centers, ridge=rbf_ridge)
        f = LinearField(alpha, beta, gs, rbf=rbf)
    return f


# --- geometry helpers ---------------------------------------------------------------------------


def similarity_transform(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Umeyama: scale s, rotation R (3, 3), translation t with dst ≈ s·R·src + t (least squares
    over corresponding points (N, 3))."""
    src = np.asarray(src, float)
    dst = np.asarray(dst, float)
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    u, sv, vt = np.linalg.svd(b.T @ a / len(src))
    sgn = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sgn[2, 2] = -1
    r = u @ sgn @ vt
    s = float(np.trace(np.diag(sv) @ sgn) / (a**2).sum(1).mean())
    return s, r, md - s * r @ ms


def _lip_line(lm: np.ndarray) -> tuple[float, np.ndarray]:
    """Mouth midline x and the inner-lip line (4, 3): centre, two mid points, corner, as
    (|x − mid|, y, z), mirrored and averaged from landmarks 60–67."""
    mid_x = 0.5 * (lm[64, 0] + lm[60, 0])
    pts = []
    for ids in ((62, 66), (61, 67, 63, 65), (60, 64)):
        q = lm[list(ids)]
        pts.append((0.0 if ids[0] == 62 else float(np.mean(np.abs(q[:, 0] - mid_x))),
                    float(q[:, 1].mean()), float(q[:, 2].mean())))
    return float(mid_x), np.asarray(pts)


def mouth_split(landmarks: np.ndarray, normal: Sequence[float] = (0.0, 1.0, 0.0),
                offsets: np.ndarray | None = None) -> dict:
    """The mouth split surface (fields-file JSON) from the 68 landmarks (cm, head frame).

    A surface through the middle of the inner lip contour (landmarks 60–67: corners 60/64,
    upper 61–63, lower 65–67): s = (v − p)·n − profile(|x|), with the profile through the lip
    line and constant beyond the corners, and a soft band outside the corners (as the built-in
    file does) so the skin stays continuous there. ``normal`` tilts the surface (the seed's
    plane through the corners may tilt); ``offsets`` (M, 2): extra offsets along the normal
    (cm) at |x| given as fractions of the mouth half-width (from :func:`refine_mouth_split`).
    """
    lm = np.asarray(landmarks, float)
    mid_x, line = _lip_line(lm)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    z0 = float(line[0, 2])
    p = np.array([mid_x, 0.0, z0])
    cx = float(line[-1, 0])
    base = np.c_[line[:, 0], (np.c_[np.zeros(len(line)), line[:, 1:]] - [0, 0, z0]) @ n]
    if offsets is not None and len(offsets):
        xs = np.asarray(offsets, float)[:, 0] * cx
        prof = np.c_[xs, np.interp(xs, base[:, 0], base[:, 1]) + np.asarray(offsets)[:, 1]]
    else:
        prof = base
    prof = np.r_[prof[prof[:, 0] < cx], [[cx, np.interp(cx, prof[:, 0], prof[:, 1])]],
                 [[30.0, np.interp(cx, prof[:, 0], prof[:, 1])]]]
    return {"point": np.round(p, 6).tolist(), "normal": np.round(n, 8).tolist(),
            "profile": np.round(prof, 6).tolist(), "soft": [0.0, round(cx, 6), 1.0]}


def refine_mouth_split(landmarks: np.ndarray, rest: np.ndarray, jaw: np.ndarray,
                       bins: int = 24) -> tuple[np.ndarray, np.ndarray, float]:
    """Tilt and offsets of the mouth split that best separate the lips as a jaw opening
    moves them: ``rest`` (N, 3) face vertices, ``jaw`` (N, 3) their displacement at a full jaw
    drop. Lip vertices near the landmark lip line are labelled lower (they drop ≥ half the
    largest drop there) or upper (≤ a quarter); over tilts of ±60°, the offsets are the
    midpoints of the gap between the classes per |x| bin, and the tilt with the widest
    smallest gap wins. Returns (normal (3,), offsets (M, 2), margin in cm)."""
    lm = np.asarray(landmarks, float)
    mid_x, line = _lip_line(lm)
    cx = float(line[-1, 0])
    ax = np.abs(rest[:, 0] - mid_x)
    y_l = np.interp(ax, line[:, 0], line[:, 1])
    z_l = np.interp(ax, line[:, 0], line[:, 2])
    near = (ax < cx) & (np.abs(rest[:, 1] - y_l) < 0.5) & (rest[:, 2] > z_l - 1.0)
    drop = float(jaw[near, 1].min()) if near.any() else 0.0
    if drop > -0.1:
        return np.array([0.0, 1.0, 0.0]), np.zeros((0, 2)), 0.0
    lower, upper = near & (jaw[:, 1] <= 0.5 * drop), near & (jaw[:, 1] >= 0.25 * drop)
    edges = np.linspace(0.0, 1.0, bins + 1)
    b = np.clip(np.searchsorted(edges, ax / cx, side="right") - 1, 0, bins - 1)
    best = (np.inf, -np.inf, np.array([0.0, 1.0, 0.0]), np.zeros((0, 2)))
    for deg in range(-60, 61, 3):
        t = np.radians(deg)
        n = np.array([0.0, np.cos(t), -np.sin(t)])
        split = Split.from_json(mouth_split(lm, n))
        sv = (rest - split.point) @ split.normal - np.interp(ax, *split.profile.T)
        offs, gaps = [], []
        for k in range(bins):
            lo_k, up_k = lower & (b == k), upper & (b == k)
            if lo_k.any() and up_k.any():
                a_k, b_k = sv[lo_k].max(), sv[up_k].min()
                gap = b_k - a_k
                gaps.append(gap)
                # stay as close to the landmark line as the gap allows (smooth profile)
                off = np.clip(0.0, a_k + 0.2 * gap, b_k - 0.2 * gap) if gap > 0 \
                    else 0.5 * (a_k + b_k)
                offs.append((0.5 * (edges[k] + edges[k + 1]), float(off)))
        if not gaps:
            continue
        final = Split.from_json(mouth_split(lm, n, np.asarray(offs)))
        w = final.upper_weight(rest)
        wrong = int((lower & (w > 0.5)).sum() + (upper & (w < 0.5)).sum())
        if (wrong, -min(gaps)) < (best[0], -best[1]):
            best = (wrong, float(min(gaps)), n, np.asarray(offs))
    wrong, margin, n, offs = best
    log.info("mouth split: tilt %.0f°, %d of %d lip vertices on the wrong side, smallest gap "
             "%.2f mm", np.degrees(np.arctan2(-n[2], n[1])), wrong, int((lower | upper).sum()),
             10 * margin)
    return n, offs, margin


def eye_split(landmarks: np.ndarray) -> dict:
    """The eye-fissure split surface (fields-file JSON) from the 68 landmarks: y =
    profile(|x|) through the middle of both eye openings (36–41 and 42–47, mirrored and
    averaged), constant beyond the corners, soft outside the openings."""
    lm = np.asarray(landmarks, float)
    mid_x = float(0.5 * (lm[39, 0] + lm[42, 0]))
    pts = []
    for ids in ((39, 42), (38, 40, 43, 47), (37, 41, 44, 46), (36, 45)):
        pts.append((float(np.mean(np.abs(lm[list(ids), 0] - mid_x))),
                    float(np.mean(lm[list(ids), 1]))))
    x_in, x_out = pts[0][0], pts[-1][0]
    prof = [(0.0, pts[0][1]), *pts, (30.0, pts[-1][1])]
    return {"point": [round(mid_x, 6), 0.0, 0.0], "normal": [0.0, 1.0, 0.0],
            "profile": np.round(np.asarray(prof), 6).tolist(),
            "soft": [round(x_in, 6), round(x_out, 6), 1.0]}


# --- the ICT fit --------------------------------------------------------------------------------


@dataclass(frozen=True)
class AuAccuracy:
    """One row of the accuracy table (seed Table 4.3), lengths in mm, on held-out vertices."""

    code: str
    obj: str  # "face" or "teeth"
    n: int
    d: float
    d_max: float
    e: float
    e_max: float
    fit_s: float = 0.0

    @property
    def e_rel(self) -> float:
        return self.e / self.d_max if self.d_max else 0.0

    @property
    def e_max_rel(self) -> float:
        return self.e_max / self.d_max if self.d_max else 0.0


@dataclass
class FitResult:
    """A fitted fields document (JSON-ready dict) and its accuracy rows."""

    document: dict
    accuracy: list[AuAccuracy] = field(default_factory=list)
    family: str = "seed"
    seconds: float = 0.0

    @property
    def mean_e_rel(self) -> float:
        rows = [r for r in self.accuracy if r.obj == "face"]
        return float(np.mean([r.e_rel for r in rows])) if rows else float("nan")


def fittable_aus(table: Mapping) -> tuple[str, ...]:
    """AUs of the ICT table that are linear shape combinations (no eye/head rotation)."""
    out = []
    for raw, spec in table.get("aus", {}).items():
        if spec.get("shapes") and not {"eye_rotate_deg", "head_rotate_deg",
                                       "head_translate_cm"} & set(spec):
            out.append(parse_au(raw))
    return tuple(c for c in AU_CATALOGUE if c in out)


def _rotation_specs(table: Mapping, head: Head) -> dict[str, dict]:
    """Head and eye motions of the ICT table as fields-file rotation/translation AUs."""
    a = head.anchors
    falloff = {"top": round(float(a["chin"][1]), 4), "bottom": round(float(a["neck_base"][1]), 4)}
    pivot = np.round(np.asarray(a["neck_pivot"], float), 4).tolist()
    out: dict[str, dict] = {}
    for raw, spec in table.get("aus", {}).items():
        code = parse_au(raw)
        for key, objects, piv in (("eye_rotate_deg", ["eyes"], "object"),
                                  ("head_rotate_deg", ["face", "eyes", "teeth"], pivot)):
            if key in spec:
                rv = np.asarray(spec[key], float)
                ang = float(np.linalg.norm(rv))
                out[code] = {"kind": "rotation", "axis": np.round(rv / ang, 8).tolist(),
                             "angle": round(ang, 6), "pivot": piv, "objects": objects}
                if piv != "object":
                    out[code]["falloff"] = dict(falloff)
        if "head_translate_cm" in spec:
            out[code] = {"kind": "translation", "vector": list(map(float, spec[
                "head_translate_cm"])), "falloff": dict(falloff),
                "objects": ["face", "eyes", "teeth"]}
    return out


def _shape_is_sided(spec: Mapping, shape_names: Sequence[str]) -> bool:
    names = set(shape_names)
    return any(f"{n}_L" in names or n[-2:] in ("_L", "_R") for n in spec.get("shapes", {}))


def fit_ict(path: str | None = None, aus: Sequence[str] | None = None,
            options: FitOptions | None = None, progress: Progress | None = None) -> FitResult:
    """Fit fields to the ICT Face Model's shapes (folder ``path`` or ``$MIMIKA_ICT_DIR``).

    ``aus``: a subset of the fittable AUs (default all); rotations (head 51–58, eyes 61–64)
    keep the ICT rig's analytic definitions and are always included.
    """
    from mimika.face.blendshape import BlendshapeRig, load_table
    from mimika.face.ict import load_ict

    opt = options or FitOptions()
    t_start = time.perf_counter()
    head, shapes = load_ict(path)
    table = load_table()
    rig = BlendshapeRig(head, shapes, table)
    avail = fittable_aus(table)
    if aus is None:
        codes = list(avail)
    else:
        codes = []
        for a in aus:
            c = parse_au(a)
            if c not in avail:
                raise ParameterError(f"{c} cannot be fitted from the ICT shapes; fittable: "
                                     f"{', '.join(avail)}")
            if c not in codes:
                codes.append(c)
    lm = head.landmark_points().astype(float)
    origin = lm.mean(0)
    scale = float(np.sqrt(((lm - origin) ** 2).sum(1).mean()))
    jaw = rig.deform({"AU27": 1.0})["skin"][FACE_RANGE[0]:FACE_RANGE[1]].astype(float)
    face_v = head["skin"].vertices[FACE_RANGE[0]:FACE_RANGE[1]].astype(float)
    normal, offsets, _ = refine_mouth_split(lm, face_v, jaw - face_v)
    split = mouth_split(lm, normal, offsets)
    doc: dict = {
        "format": "mimika-fields", "version": 1, "head": "ict",
        "description": f"Fitted to the ICT Face Model Light shapes by 'mimika fit' "
                       f"(family {opt.family}, seed 002 Eq 4.8/4.9).",
        "frame": {"origin": np.round(origin, 6).tolist(), "scale": round(scale, 6)},
        "splits": {"mouth": split},
        "source": {"head": "ict", "landmarks": np.round(lm, 5).tolist(),
                   "mouth_split": {"normal": np.round(normal, 8).tolist(),
                                   "offsets": np.round(offsets, 6).tolist()},
                   "fit": {"family": opt.family, "seed": opt.seed}},
        "aus": {},
    }
    if opt.lid_split:
        doc["splits"]["eyes"] = eye_split(lm)
    probe = parse_fields({**doc, "aus": {}})
    # every face-category object is driven by the face field: fit on all of them (skin,
    # mouth socket, eye sockets, lashes), measure on the ICT face range of the skin only
    face_names = [o.name for o in head.objects if o.category == "face"]
    rest = np.concatenate([head[n].vertices for n in face_names]).astype(float)
    off = {n: int(o) for n, o in zip(face_names, np.cumsum(
        [0] + [head[n].n_vertices for n in face_names]), strict=False)}
    lo, hi = off["skin"] + FACE_RANGE[0], off["skin"] + FACE_RANGE[1]
    in_face = np.zeros(len(rest), bool)
    in_face[lo:hi] = True
    upper = {name: sp.upper_weight(rest) for name, sp in probe.splits.items()}
    teeth_names = [o.name for o in head.objects if o.category == "teeth"]
    teeth_rest = np.concatenate([head[n].vertices for n in teeth_names]).astype(float)
    to_u = probe.to_u
    s_min = opt.sigma_min_cm / scale
    fit_kw = dict(family=opt.family, sigma_min=s_min, psi_evals=opt.psi_evals,
                  phi_evals=opt.phi_evals, rbf_centers=opt.rbf_centers, rbf_ridge=opt.rbf_ridge)
    heldout: dict[str, np.ndarray] = {}
    measured: dict[str, np.ndarray] = {}
    times: dict[str, float] = {}
    for k, code in enumerate(codes):
        t0 = time.perf_counter()
        rng = np.random.default_rng([opt.seed, int(code[2:4])])
        spec = table["aus"][code]
        pose = {code + "L": 1.0, code + "R": 1.0} if AU_CATALOGUE[code].sided else {code: 1.0}
        pos = rig.deform(pose)
        disp = np.concatenate([pos[n] for n in face_names]).astype(float) - rest
        measured[code] = disp[off["skin"]:off["skin"] + head["skin"].n_vertices]
        mag = np.linalg.norm(disp, axis=1)
        thr = max(opt.moving_min_cm, opt.moving_fraction * float(mag[lo:hi].max()))
        moves = mag >= thr
        mov = np.flatnonzero(moves & in_face)
        perm = rng.permutation(mov)
        n_test = round(opt.holdout * len(perm))
        heldout[code] = np.sort(perm[:n_test]) - off["skin"]
        train = np.sort(np.r_[perm[n_test:], np.flatnonzero(moves & ~in_face)])
        # still vertices near the motion (target 0)
        box_lo, box_hi = rest[mov].min(0) - 1.5, rest[mov].max(0) + 1.5
        still = np.flatnonzero(~moves & np.all((rest >= box_lo) & (rest <= box_hi), axis=1))
        still = rng.permutation(still)[:opt.still_vertices]
        bilateral = _shape_is_sided(spec, shapes.names)
        split = "mouth" if code in SUB_OBJECT or (opt.lid_split and code in JAW_AUS) \
            else "eyes" if (opt.lid_split and code in LID_AUS) else None
        if split is None:
            halves: tuple = ((None, np.ones(len(rest), bool)),)
        else:
            halves = (("upper", upper[split] > 0.0), ("lower", upper[split] < 1.0))
        face_spec: dict = {}
        for half, sel in halves:
            tr = train[sel[train]]
            tr = rng.permutation(tr)[:opt.max_vertices] if len(tr) > opt.max_vertices else tr
            st = still[sel[still]]
            if len(tr) < 8:
                log.info("%s %s: only %d moving vertices; no field", code, half, len(tr))
                continue
            idx = np.r_[tr, st]
            moving = np.r_[np.ones(len(tr), bool), np.zeros(len(st), bool)]
            f = fit_field(to_u(rest[idx]), disp[idx] / scale, moving,
                          bilateral=bilateral, **fit_kw)
            if half is None:
                face_spec = f.to_json()
            else:
                face_spec[half] = f.to_json()
        if split is not None and face_spec and split != "mouth":
            face_spec["split"] = split
        objects = {"face": face_spec} if face_spec else {}
        # teeth: the lower teeth, gums and tongue follow the jaw (seed: AU26/27 move teeth)
        tpos = np.concatenate([pos[n] for n in teeth_names]).astype(float)
        tdisp = tpos - teeth_rest
        tmag = np.linalg.norm(tdisp, axis=1)
        if tmag.max() > 0.05:
            tmov = np.flatnonzero(tmag >= max(opt.moving_min_cm, opt.moving_fraction *
                                              tmag.max()))
            tsel = rng.permutation(tmov)[:opt.max_vertices]
            f = fit_field(to_u(teeth_rest[tsel]), tdisp[tsel] / scale, None,
                          bilateral=False, **fit_kw)
            objects["teeth"] = {"lower": f.to_json()}
            heldout[code + ":teeth"] = tmov
            measured[code + ":teeth"] = tdisp
        if objects:
            doc["aus"][code] = {"kind": "linear", "objects": objects}
        times[code] = time.perf_counter() - t0
        log.info("fitted %s in %.2f s (%d moving face vertices)", code, times[code], len(mov))
        if progress:
            progress(k + 1, len(codes))
    doc["aus"].update(_rotation_specs(table, head))
    doc["aus"] = {c: doc["aus"][c] for c in AU_CATALOGUE if c in doc["aus"]}
    accuracy = _accuracy(doc, head, codes, measured, heldout, teeth_names, times)
    return FitResult(doc, accuracy, opt.family, time.perf_counter() - t_start)


def _accuracy(doc: dict, head: Head, codes: Sequence[str], measured: Mapping[str, np.ndarray],
              heldout: Mapping[str, np.ndarray], teeth_names: Sequence[str],
              times: Mapping[str, float]) -> list[AuAccuracy]:
    """Table 4.3 rows through a FieldRig built from ``doc`` (the file as written)."""
    rig = FieldRig(head, parse_fields(doc, source="<fit>"))
    rows = []
    for code in codes:
        if code not in rig.fields.linear:
            continue
        for obj, key in (("face", code), ("teeth", code + ":teeth")):
            if key not in heldout or len(heldout[key]) == 0:
                continue
            if obj == "face":
                model = rig.field_at(code, "skin", head["skin"].vertices)
            else:
                # the lower-teeth field itself, per vertex: the ICT head's teeth object holds
                # both rows, so the FieldRig's whole-object side rule cannot be measured here
                lower = rig.fields.linear[code]["teeth"].lower
                v = np.concatenate([head[n].vertices for n in teeth_names])
                model = rig.fields.to_head(lower(rig.fields.to_u(v)))
            ids = heldout[key]
            meas = measured[key][ids]
            dm = np.linalg.norm(meas, axis=1) * 10.0
            err = np.linalg.norm(meas - model[ids], axis=1) * 10.0
            rows.append(AuAccuracy(code, obj, len(ids), float(dm.mean()), float(dm.max()),
                                   float(err.mean()), float(err.max()),
                                   times.get(code, 0.0) if obj == "face" else 0.0))
    return rows


# --- reports ------------------------------------------------------------------------------------

_COLS = ("AU", "object", "n", "d", "d_max", "e", "e_max", "e/d_max", "e_max/d_max")


def _row(r: AuAccuracy) -> list[str]:
    return [r.code, r.obj, str(r.n), f"{r.d:.3f}", f"{r.d_max:.3f}", f"{r.e:.3f}",
            f"{r.e_max:.3f}", f"{r.e_rel:.4f}", f"{r.e_max_rel:.4f}"]


def report_csv(rows: Sequence[AuAccuracy]) -> str:
    """The accuracy rows as CSV text (lengths in mm)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(_COLS)
    for r in rows:
        w.writerow(_row(r))
    return buf.getvalue()


def _summary(rows: Sequence[AuAccuracy]) -> dict[str, float]:
    face = [r for r in rows if r.obj == "face"]
    if not face:
        return {}
    return {k: float(np.mean([getattr(r, k) for r in face]))
            for k in ("d", "d_max", "e", "e_max", "e_rel", "e_max_rel")}


def report_markdown(rows: Sequence[AuAccuracy], title: str = "") -> str:
    """The accuracy rows as a Markdown table (lengths in mm) with the mean over face rows."""
    lines = [f"### {title}", ""] if title else []
    lines += ["| " + " | ".join(_COLS) + " |", "|" + "---|" * len(_COLS)]
    lines += ["| " + " | ".join(_row(r)) + " |" for r in rows]
    s = _summary(rows)
    if s:
        lines.append(f"| **mean (face)** | | | {s['d']:.3f} | {s['d_max']:.3f} | {s['e']:.3f} "
                     f"| {s['e_max']:.3f} | **{s['e_rel']:.4f}** | {s['e_max_rel']:.4f} |")
    return "\n".join(lines) + "\n"


# --- transfer -----------------------------------------------------------------------------------


def transfer_fields(doc: Mapping, target: Head, *,
                    source_landmarks: np.ndarray | None = None) -> dict:
    """Carry a fields document to ``target`` (a new document; ``doc`` is not changed).

    The source landmarks (``doc["source"]["landmarks"]`` unless given) are aligned to the
    target's 68 landmarks by a similarity transform v_t ≈ s·R·v_s + t; the field frame becomes
    origin' = t + s·R·origin, scale' = s·scale, rotation' = R_old·Rᵀ (so u is unchanged for
    corresponding points and displacements map by s·R). Split surfaces are rebuilt from the
    target's landmarks (:func:`mouth_split`); head rotations/translations use the target's
    anchors (neck pivot, chin, neck base) and map their axes/vectors by R.
    """
    src = source_landmarks
    if src is None:
        try:
            src = np.asarray(doc["source"]["landmarks"], float)
        except (KeyError, TypeError):
            raise DataError("the fields file has no source landmarks (source.landmarks): it "
                            "was not written by 'mimika fit'; cannot transfer it") from None
    src = np.asarray(src, float).reshape(-1, 3)
    dst = target.landmark_points().astype(float)
    if src.shape != dst.shape:
        raise DataError(f"source has {len(src)} landmarks, target {len(dst)}")
    s, r, t = similarity_transform(src, dst)
    resid = np.linalg.norm(s * src @ r.T + t - dst, axis=1)
    log.info("transfer: scale %.4f, rotation %.2f°, landmark rms %.3f cm", s,
             np.degrees(np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1))),
             float(np.sqrt((resid**2).mean())))
    import copy

    out = copy.deepcopy(dict(doc))
    frame = out.get("frame", {})
    o = np.asarray(frame.get("origin", [0, 0, 0]), float)
    r_old = np.asarray(frame.get("rotation", np.eye(3)), float)
    frame = {"origin": np.round(t + s * r @ o, 6).tolist(),
             "scale": round(float(frame.get("scale", 1.0)) * s, 8),
             "rotation": np.round(r_old @ r.T, 10).tolist()}
    out["frame"] = frame
    ms = (doc.get("source") or {}).get("mouth_split") or {}
    normal = r @ np.asarray(ms.get("normal", [0.0, 1.0, 0.0]), float)
    offsets = np.asarray(ms.get("offsets", np.zeros((0, 2))), float).reshape(-1, 2)
    offsets = offsets * [1.0, s]  # |x| fractions stay, offsets (cm) scale
    splits = {**out.get("splits", {}), "mouth": mouth_split(dst, normal, offsets)}
    if "eyes" in splits:
        splits["eyes"] = eye_split(dst)
    out["splits"] = splits
    out.pop("split", None)
    a = target.anchors
    for spec in out.get("aus", {}).values():
        kind = spec.get("kind", "linear")
        if kind == "linear":
            continue
        if "axis" in spec:
            spec["axis"] = np.round(r @ np.asarray(spec["axis"], float), 8).tolist()
        if "vector" in spec:
            spec["vector"] = np.round(s * r @ np.asarray(spec["vector"], float), 6).tolist()
        if spec.get("pivot", "object") != "object" and "neck_pivot" in a:
            spec["pivot"] = np.round(np.asarray(a["neck_pivot"], float), 4).tolist()
        if "falloff" in spec and "chin" in a and "neck_base" in a:
            spec["falloff"] = {"top": round(float(a["chin"][1]), 4),
                               "bottom": round(float(a["neck_base"][1]), 4)}
    src_info = dict(out.get("source", {}))
    out["source"] = {**src_info, "head": target.name, "landmarks": np.round(dst, 5).tolist(),
                     "transferred_from": src_info.get("head", "?"),
                     "mouth_split": {"normal": np.round(normal, 8).tolist(),
                                     "offsets": np.round(offsets, 6).tolist()},
                     "similarity": {"scale": s, "rotation": np.round(r, 8).tolist(),
                                    "translation": np.round(t, 6).tolist()}}
    out["head"] = target.name
    return out


def read_fields_json(path: str | Path) -> dict:
    """A fields file as a dict (errors name the file, line and column)."""
    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except OSError as e:
        raise DataError(f"cannot read fields file {p}: {e.strerror}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise DataError(f"{p}:{e.lineno}:{e.colno}: invalid JSON: {e.msg}") from None


#: landmark rms (cm) above which a fitted file is aligned to the head it is loaded on
ALIGN_TOLERANCE_CM = 0.05


def load_fitted_rig(head: Head, path: str | Path) -> FieldRig:
    """A :class:`FieldRig` on ``head`` from a fields file; a file that records the landmarks
    it was fitted on (``source.landmarks``, written by ``mimika fit``) is first carried to
    ``head`` by :func:`transfer_fields` when they differ from the head's (rms > 0.5 mm)."""
    doc = read_fields_json(path)
    src = (doc.get("source") or {}).get("landmarks") if isinstance(doc, dict) else None
    if src is not None:
        src = np.asarray(src, float)
        lm = head.landmark_points().astype(float)
        if src.shape == lm.shape and np.sqrt(((src - lm) ** 2).sum(1).mean()) > \
                ALIGN_TOLERANCE_CM:
            log.info("aligning fields %s to head %r by its landmarks", path, head.name)
            doc = transfer_fields(doc, head)
    return FieldRig(head, parse_fields(doc, source=str(path)))


def landmark_agreement(src_rig, dst_rig, codes: Sequence[str], *, rotation: np.ndarray | None
                       = None, moving: float = 0.2) -> dict[str, tuple[float, float, int]]:
    """Do AUs move the same landmarks the same way on two rigs? Per AU: (mean cosine, min
    cosine, number of landmarks) between the landmark displacements at τ = 1 on ``src_rig``
    (rotated by ``rotation``, the source → target similarity) and on ``dst_rig``, over the
    landmarks whose source displacement is ≥ ``moving`` × the AU's largest one."""
    r = np.eye(3) if rotation is None else np.asarray(rotation, float)
    l0s = src_rig.head.landmark_points().astype(float)
    l0d = dst_rig.head.landmark_points().astype(float)
    out = {}
    for code in codes:
        ds = (src_rig.head.landmark_points(src_rig.deform({code: 1.0})) - l0s) @ r.T
        dd = dst_rig.head.landmark_points(dst_rig.deform({code: 1.0})) - l0d
        ns, nd = np.linalg.norm(ds, axis=1), np.linalg.norm(dd, axis=1)
        sel = ns >= moving * ns.max() if ns.max() > 0 else np.zeros(len(ns), bool)
        if not sel.any():
            continue
        cos = (ds[sel] * dd[sel]).sum(1) / np.maximum(ns[sel] * nd[sel], 1e-12)
        out[code] = (float(cos.mean()), float(cos.min()), int(sel.sum()))
    return out
