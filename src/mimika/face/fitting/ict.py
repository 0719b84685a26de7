"""Fit seed 002's AU fields to measured (scanned) shapes and carry them to other faces.

Seed 002 §4.2 fits, per AU, a direction field Ψ (polar angles α, β: cubic polynomials of the
position, Eq 4.3–4.5) and a density φ (one Gaussian, two for bilateral AUs, Eq 4.6–4.7) to the
displacements neutral → AU at full intensity, with Nelder–Mead, Ψ first then φ:

    E_Ψ = Σᵢ |Δvᵢ − |Δvᵢ|·Ψ(vᵢ)|        (Eq 4.8)
    E_φ = Σᵢ (|Δvᵢ| − φ(vᵢ))²            (Eq 4.9)

This module fits them to the ICT Face Model's light-stage shapes, composed per AU by the
:class:`~mimika.face.rigs.blendshape.BlendshapeRig` at τ = 1 (so derived AUs such as AU25/26 use the
same composition as the ICT head). Two function families:

``seed``
    the seed's Ψ·φ, fitted as the seed does (Nelder–Mead, E_Ψ then E_φ), from least-squares
    initial values (angles by weighted linear least squares, Gaussians from weighted moments).
``rich``
    the seed's fit plus a smooth vector residual Σₖ wₖ·exp(−|u−cₖ|²/2σ²) on up to
    ``rbf_centers`` centres (farthest-point samples of the moving vertices), solved by ridge
    least squares and stored in the fields file (``rbf`` key, see docs/rigs.md).

Accuracy (seed Table 4.3: n, d, d_max, e, e_max, in mm) is measured through a
:class:`~mimika.face.rigs.field.FieldRig` built from the written document, on held-out moving
vertices (a fixed random half never used in fitting).

Transfer to other heads: :mod:`mimika.face.fitting.transfer`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from mimika.errors import ParameterError
from mimika.face.fitting.optimize import fit_field
from mimika.face.fitting.report import AuAccuracy
from mimika.face.fitting.splits import eye_split, mouth_split, refine_mouth_split
from mimika.face.head import Head
from mimika.face.rigs.field import (
    FieldRig,
    FieldSet,
    parse_fields,
)
from mimika.facs import AU_CATALOGUE, parse_au

log = logging.getLogger(__name__)


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



# --- the ICT fit --------------------------------------------------------------------------------


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


@dataclass
class _Setup:
    """What every field fit on the ICT head shares: the fields frame, the split surfaces, the
    face-category vertices (all objects the face field drives) and the teeth vertices."""

    head: Head
    doc: dict
    opt: FitOptions
    face_names: list[str]
    rest: np.ndarray
    off: dict[str, int]
    in_face: np.ndarray
    upper: dict[str, np.ndarray]
    teeth_names: list[str]
    teeth_rest: np.ndarray
    fit_kw: dict
    scale: float


def _setup(head: Head, jaw_skin: np.ndarray, opt: FitOptions, what: str,
           face: np.ndarray | None = None, source: str = "ict") -> _Setup:
    """Frame (landmark centroid and rms radius), mouth split refined on the jaw-open skin
    positions ``jaw_skin``, eye split (rich), and the vertex sets of ``head`` (ICT by default;
    ``face``: which skin vertices are the face, default the ICT face range; ``source``: the
    head's name in the document)."""
    if face is None:
        face = np.zeros(head["skin"].n_vertices, bool)
        face[FACE_RANGE[0]:FACE_RANGE[1]] = True
    lm = head.landmark_points().astype(float)
    origin = lm.mean(0)
    scale = float(np.sqrt(((lm - origin) ** 2).sum(1).mean()))
    jaw = jaw_skin[face].astype(float)
    face_v = head["skin"].vertices[face].astype(float)
    normal, offsets, _ = refine_mouth_split(lm, face_v, jaw - face_v)
    split = mouth_split(lm, normal, offsets)
    shapes = "the ICT Face Model Light shapes" if source == "ict" else f"{source}'s shapes"
    doc: dict = {
        "format": "mimika-fields", "version": 1, "head": source,
        "description": f"Fitted to {shapes} by 'mimika fit' "
                       f"(family {opt.family}, seed 002 Eq 4.8/4.9{what}).",
        "frame": {"origin": np.round(origin, 6).tolist(), "scale": round(scale, 6)},
        "splits": {"mouth": split},
        "source": {"head": source, "landmarks": np.round(lm, 5).tolist(),
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
    in_face = np.zeros(len(rest), bool)
    in_face[off["skin"]:off["skin"] + len(face)] = face
    upper = {name: sp.upper_weight(rest) for name, sp in probe.splits.items()}
    teeth_names = [o.name for o in head.objects if o.category == "teeth"]
    teeth_rest = np.concatenate([head[n].vertices for n in teeth_names]).astype(float)
    fit_kw = dict(family=opt.family, sigma_min=opt.sigma_min_cm / scale,
                  psi_evals=opt.psi_evals, phi_evals=opt.phi_evals,
                  rbf_centers=opt.rbf_centers, rbf_ridge=opt.rbf_ridge)
    return _Setup(head, doc, opt, face_names, rest, off, in_face, upper, teeth_names,
                  teeth_rest, fit_kw, scale)


def _fit_objects(st: _Setup, pos: Mapping[str, np.ndarray], rng: np.random.Generator,
                 split: str | None, bilateral: bool, key: str, heldout: dict, measured: dict
                 ) -> tuple[dict, int]:
    """Fit the face (and lower-teeth) fields of one displacement ``pos`` (positions per object
    at full intensity); records held-out skin vertices and measurements under ``key``.
    Returns the ``objects`` spec of the fields file and the number of moving face vertices."""
    opt, rest, head = st.opt, st.rest, st.head
    to_u = parse_fields({**st.doc, "aus": {}}).to_u
    disp = np.concatenate([pos[n] for n in st.face_names]).astype(float) - rest
    measured[key] = disp[st.off["skin"]:st.off["skin"] + head["skin"].n_vertices]
    mag = np.linalg.norm(disp, axis=1)
    thr = max(opt.moving_min_cm, opt.moving_fraction * float(mag[st.in_face].max()))
    moves = mag >= thr
    mov = np.flatnonzero(moves & st.in_face)
    perm = rng.permutation(mov)
    n_test = round(opt.holdout * len(perm))
    heldout[key] = np.sort(perm[:n_test]) - st.off["skin"]
    train = np.sort(np.r_[perm[n_test:], np.flatnonzero(moves & ~st.in_face)])
    # still vertices near the motion (target 0)
    box_lo, box_hi = rest[mov].min(0) - 1.5, rest[mov].max(0) + 1.5
    still = np.flatnonzero(~moves & np.all((rest >= box_lo) & (rest <= box_hi), axis=1))
    still = rng.permutation(still)[:opt.still_vertices]
    if split is None:
        halves: tuple = ((None, np.ones(len(rest), bool)),)
    else:
        halves = (("upper", st.upper[split] > 0.0), ("lower", st.upper[split] < 1.0))
    face_spec: dict = {}
    for half, sel in halves:
        tr = train[sel[train]]
        tr = rng.permutation(tr)[:opt.max_vertices] if len(tr) > opt.max_vertices else tr
        sti = still[sel[still]]
        if len(tr) < 8:
            log.info("%s %s: only %d moving vertices; no field", key, half, len(tr))
            continue
        idx = np.r_[tr, sti]
        moving = np.r_[np.ones(len(tr), bool), np.zeros(len(sti), bool)]
        f = fit_field(to_u(rest[idx]), disp[idx] / st.scale, moving,
                      bilateral=bilateral, **st.fit_kw)
        if half is None:
            face_spec = f.to_json()
        else:
            face_spec[half] = f.to_json()
    if split is not None and face_spec and split != "mouth":
        face_spec["split"] = split
    objects = {"face": face_spec} if face_spec else {}
    # teeth: the lower teeth, gums and tongue follow the jaw (seed: AU26/27 move teeth)
    tpos = np.concatenate([pos[n] for n in st.teeth_names]).astype(float)
    tdisp = tpos - st.teeth_rest
    tmag = np.linalg.norm(tdisp, axis=1)
    if tmag.max() > 0.05:
        tmov = np.flatnonzero(tmag >= max(opt.moving_min_cm, opt.moving_fraction *
                                          tmag.max()))
        tsel = rng.permutation(tmov)[:opt.max_vertices]
        f = fit_field(to_u(st.teeth_rest[tsel]), tdisp[tsel] / st.scale, None,
                      bilateral=False, **st.fit_kw)
        objects["teeth"] = {"lower": f.to_json()}
        heldout[key + ":teeth"] = tmov
        measured[key + ":teeth"] = tdisp
    return objects, len(mov)


def fit_ict(path: str | None = None, aus: Sequence[str] | None = None,
            options: FitOptions | None = None, progress: Progress | None = None) -> FitResult:
    """Fit fields to the ICT Face Model's shapes (folder ``path`` or ``$MIMIKA_ICT_DIR``).

    ``aus``: a subset of the fittable AUs (default all); rotations (head 51–58, eyes 61–64)
    keep the ICT rig's analytic definitions and are always included.
    """
    from mimika.face.heads.ict import load_ict
    from mimika.face.rigs.blendshape import BlendshapeRig, load_table

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
    st = _setup(head, rig.deform({"AU27": 1.0})["skin"], opt, "")
    doc = st.doc
    heldout: dict[str, np.ndarray] = {}
    measured: dict[str, np.ndarray] = {}
    times: dict[str, float] = {}
    for k, code in enumerate(codes):
        t0 = time.perf_counter()
        rng = np.random.default_rng([opt.seed, int(code[2:4])])
        spec = table["aus"][code]
        pose = {code + "L": 1.0, code + "R": 1.0} if AU_CATALOGUE[code].sided else {code: 1.0}
        bilateral = _shape_is_sided(spec, shapes.names)
        split = "mouth" if code in SUB_OBJECT or (opt.lid_split and code in JAW_AUS) \
            else "eyes" if (opt.lid_split and code in LID_AUS) else None
        objects, n_mov = _fit_objects(st, rig.deform(pose), rng, split, bilateral, code,
                                      heldout, measured)
        if objects:
            doc["aus"][code] = {"kind": "linear", "objects": objects}
        times[code] = time.perf_counter() - t0
        log.info("fitted %s in %.2f s (%d moving face vertices)", code, times[code], n_mov)
        if progress:
            progress(k + 1, len(codes))
    doc["aus"].update(_rotation_specs(table, head))
    doc["aus"] = {c: doc["aus"][c] for c in AU_CATALOGUE if c in doc["aus"]}
    accuracy = accuracy_rows(parse_fields(doc, source="<fit>"), head, codes, measured, heldout,
                             st.teeth_names, times)
    return FitResult(doc, accuracy, opt.family, time.perf_counter() - t_start)


def accuracy_rows(fields: FieldSet, head: Head, codes: Sequence[str],
                  measured: Mapping[str, np.ndarray], heldout: Mapping[str, np.ndarray],
                  teeth_names: Sequence[str], times: Mapping[str, float]) -> list[AuAccuracy]:
    """Table 4.3 rows through a FieldRig built from ``fields`` (the file as written); ``codes``
    are keys of ``fields.linear`` (AUs, or shape names for shape fields)."""
    rig = FieldRig(head, fields)
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
