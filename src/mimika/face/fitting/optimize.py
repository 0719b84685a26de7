"""Seed 002 §4.2 field fitting: Ψ (Eq 4.8) and φ (Eq 4.9) by Nelder–Mead, and the rich
family's RBF residual, for one AU's displacements."""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

import numpy as np
from scipy.optimize import minimize

from mimika.errors import ParameterError
from mimika.face.rigs.field import (
    Cubic,
    Gaussian,
    LinearField,
    Rbf,
)

log = logging.getLogger(__name__)


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
