"""A blendshape rig: AUs → weighted sums of shape deltas, eyeball and head rotations.

Order (seed 002's default mixer): sum of shape deltas (additive) → eyeball rotations about
each eye pivot → head rotation/translation about ``neck_pivot`` applied last to all objects,
weighted by a smooth neck fall-off (1 above the chin, smoothstep to 0 at the neck base).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.face.head import Head
from mimika.face.rig import Positions, Rig, split_sides
from mimika.facs import AU_CATALOGUE, base_code, parse_au
from mimika.facs.shapes import au_shape_table

log = logging.getLogger(__name__)

__all__ = ["BlendshapeRig", "ShapeSet", "load_table"]

_EPS = 1e-5  #: cm; smaller deltas count as "does not move"
_CHUNK = 128  #: frames per block in deform_batch (bounds temporary memory)
_GAP = 16  #: moving-vertex runs closer than this many vertices are merged into one segment


@dataclass(frozen=True)
class ShapeSet:
    """Blendshape deltas per object: ``deltas[obj]`` has shape (S, N_obj, 3), float32."""

    names: tuple[str, ...]
    deltas: Mapping[str, np.ndarray]


def load_table(name: str = "ict_aus.json") -> dict:
    """The AU → shape table: ICT's (:func:`mimika.facs.shapes.au_shape_table`) or another
    shipped in ``mimika/face/data`` (``makehuman_aus.json``)."""
    if name == "ict_aus.json":
        return au_shape_table()
    text = resources.files("mimika.face").joinpath("data", name).read_text("utf-8")
    return json.loads(text)


def _rotmat(rv: np.ndarray) -> np.ndarray:
    """Rotation matrices from rotation vectors (radians), (T, 3) → (T, 3, 3) float64."""
    rv = np.asarray(rv, np.float64).reshape(-1, 3)
    th = np.sqrt((rv * rv).sum(1))
    k = rv / np.where(th > 1e-12, th, 1.0)[:, None]
    c, s = np.cos(th), np.sin(th)
    kmat = np.zeros((len(rv), 3, 3))
    kmat[:, 0, 1], kmat[:, 0, 2], kmat[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    kmat[:, 1, 0], kmat[:, 2, 0], kmat[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    out = (1 - c)[:, None, None] * (k[:, :, None] * k[:, None, :]) + s[:, None, None] * kmat
    out[:, [0, 1, 2], [0, 1, 2]] += c[:, None]
    return out


def _smoothstep(t: np.ndarray) -> np.ndarray:
    """3t² − 2t³ of t clipped to [0, 1]."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _add3(x: np.ndarray, off: np.ndarray, k: int = 64) -> None:
    """``x += off`` for x (N, 3) contiguous and off (3,); numpy broadcasts over a length-3
    inner axis slowly, so add on (N·3/3k, 3k) blocks with ``off`` tiled k times."""
    flat = x.reshape(-1)
    n = (len(flat) // (3 * k)) * 3 * k
    flat[:n].reshape(-1, 3 * k).__iadd__(np.tile(off.astype(x.dtype), k))
    flat[n:].reshape(-1, 3).__iadd__(off.astype(x.dtype))


class BlendshapeRig(Rig):
    """AU rig over a :class:`Head` and its blendshape deltas, driven by an AU table.

    ``table`` is the parsed ``ict_aus.json`` layout: ``{"aus": {code: {"shapes": {name: w},
    "eye_rotate_deg": [x, y, z], "head_rotate_deg": …, "head_translate_cm": …}}}``.
    """

    def __init__(self, head: Head, shapes: ShapeSet, table: Mapping) -> None:
        self.head = head
        self._names = [o.name for o in head.objects]
        sizes = [o.n_vertices for o in head.objects]
        self._offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self._slices = {
            n: slice(int(self._offsets[i]), int(self._offsets[i + 1]))
            for i, n in enumerate(self._names)
        }
        rest = np.concatenate([o.vertices for o in head.objects]).astype(np.float32)
        rest.setflags(write=False)
        self._rest = rest
        n_tot = len(rest)
        width = float(table.get("side_mask_width_cm", 0.8))
        mask_l = 0.5 * (1.0 + np.tanh(rest[:, 0].astype(np.float64) / width))
        masks = {"L": mask_l, "R": 1.0 - mask_l}

        # shapes leave the back of the skull and the neck base still (scan noise there):
        # deltas fade to 0 for z below still_back_z_cm[0] and within still_neck_band_cm of the
        # neck base; weight 1 from still_back_z_cm[1] forward and above the band
        z0, z1 = table.get("still_back_z_cm", [-1e9, -1e9 + 1])
        band = float(table.get("still_neck_band_cm", 0.0))
        still = _smoothstep((rest[:, 2] - z0) / max(z1 - z0, 1e-6))
        if band > 0:
            still *= _smoothstep((rest[:, 1] - head.anchors["neck_base"][1]) / band)
        still = still.astype(np.float32)[:, None]

        shape_index = {s: i for i, s in enumerate(shapes.names)}
        for obj, d in shapes.deltas.items():
            if obj in self._slices and d.shape != (len(shapes.names), *head[obj].vertices.shape):
                raise DataError(f"shape deltas for {obj!r} have shape {d.shape}, expected "
                                f"({len(shapes.names)}, {head[obj].n_vertices}, 3)")

        def full_delta(name: str) -> np.ndarray:
            out = np.zeros((n_tot, 3), np.float32)
            k = shape_index[name]
            for obj, d in shapes.deltas.items():
                if obj in self._slices:
                    out[self._slices[obj]] = d[k]
            return out * still

        def side_delta(name: str, side: str) -> np.ndarray | None:
            if name[-2:] in ("_L", "_R"):
                if name not in shape_index:
                    raise DataError(f"AU table names shape {name!r}, which the head lacks")
                return full_delta(name) if name[-1] == side else None
            if f"{name}_{side}" in shape_index:
                return full_delta(f"{name}_{side}")
            if name in shape_index:
                return (full_delta(name) * masks[side][:, None]).astype(np.float32)
            raise DataError(f"AU table names shape {name!r}, which the head lacks "
                            f"(known: {', '.join(shapes.names)})")

        aus = table.get("aus", {})
        codes: list[str] = []
        rows: list[np.ndarray] = []
        self._eye_rot: dict[str, np.ndarray] = {}
        self._head_rot: dict[str, np.ndarray] = {}
        self._head_tr: dict[str, np.ndarray] = {}
        self._bilateral_side: dict[str, str] = {}
        for raw, spec in aus.items():
            code = parse_au(raw)
            if code != base_code(code):
                raise DataError(f"AU table: use bilateral codes as keys, got {raw!r}")
            if spec.get("shapes"):
                for side in ("L", "R"):
                    acc = np.zeros((n_tot, 3), np.float32)
                    for name, w in spec["shapes"].items():
                        d = side_delta(name, side)
                        if d is not None:
                            acc += np.float32(w) * d
                    rows.append(acc)
                codes.append(code)
            if "eye_rotate_deg" in spec:
                self._eye_rot[code] = np.radians(np.asarray(spec["eye_rotate_deg"], float))
            if "head_rotate_deg" in spec:
                self._head_rot[code] = np.radians(np.asarray(spec["head_rotate_deg"], float))
            if "head_translate_cm" in spec:
                self._head_tr[code] = np.asarray(spec["head_translate_cm"], float)
            if spec.get("bilateral_side"):
                self._bilateral_side[code] = str(spec["bilateral_side"]).upper()
        self._shape_codes = tuple(codes)
        self._row = {c: 2 * i for i, c in enumerate(codes)}  # left row; right row = +1
        #: (AUs, full_at) of ``release`` in the table (lips a rest pose holds together):
        #: its shapes, one row after the AUs', weigh smoothstep(largest of those AUs / full_at)
        self.release: tuple[tuple[str, ...], float] | None = None
        rel = table.get("release")
        if rel and rel.get("shapes"):
            missing = [n for n in rel["shapes"] if n not in shape_index]
            if missing or not rel.get("by") or not float(rel.get("full_at", 0)) > 0:
                raise DataError(f"AU table release: needs shapes the head has (lacks "
                                f"{missing}), AUs in 'by' and full_at > 0")
            rows.append(sum(np.float32(w) * full_delta(n) for n, w in rel["shapes"].items()))
            self.release = (tuple(parse_au(c) for c in rel["by"]), float(rel["full_at"]))
        full = np.stack(rows) if rows else np.zeros((0, n_tot, 3), np.float32)
        moved = np.flatnonzero(np.any(np.abs(full) > _EPS, axis=(0, 2)))
        # bridge gaps of < _GAP still vertices so the moving set is a few contiguous segments
        if len(moved):
            brk = np.flatnonzero(np.diff(moved) > _GAP)
            starts = np.r_[moved[0], moved[brk + 1]]
            ends = np.r_[moved[brk], moved[-1]] + 1
        else:
            starts = ends = np.zeros(0, np.int64)
        moving = np.concatenate([np.arange(a, b) for a, b in zip(starts, ends, strict=True)]
                                ) if len(moved) else np.zeros(0, np.int64)
        cols = np.concatenate([[0], np.cumsum(ends - starts)]) * 3
        #: (flat start, flat end, column start) of each segment, in x/y/z-interleaved floats
        self._segments = [(int(a) * 3, int(b) * 3, int(c))
                          for a, b, c in zip(starts, ends, cols[:-1], strict=True)]
        #: compact delta matrix (2·A, 3·M) over the M moving vertices (L/R row per AU), read-only
        self.delta_matrix = np.ascontiguousarray(full[:, moving].reshape(len(rows), -1))
        self.delta_matrix.setflags(write=False)
        #: (M,) vertex indices (into the concatenated objects) the delta matrix covers
        self.moving = moving.astype(np.int64)
        self.moving.setflags(write=False)
        del full

        sup: list[str] = []
        for code in aus:
            c = parse_au(code)
            sup.append(c)
            if AU_CATALOGUE[c].sided and c in self._row:
                sup += [c + "L", c + "R"]
        self._supported = tuple(sup)

        # eyes and head fall-off
        self._eyes = [(o.name, np.asarray(o.pivot, np.float64)) for o in head.objects
                      if o.category == "eyes" and o.pivot is not None]
        a = head.anchors
        self._neck_pivot = np.asarray(a["neck_pivot"], np.float64)
        y_top, y_bot = float(a["chin"][1]), float(a["neck_base"][1])
        w = _smoothstep((rest[:, 1] - y_bot) / max(y_top - y_bot, 1e-6))
        self.neck_weight = w.astype(np.float32)  #: (N_total,) head-motion weight per vertex
        self._partial = np.flatnonzero(w < 1.0 - 1e-9)  # bending neck (and still base)
        self._wp = w[self._partial].astype(np.float32)
        log.debug("BlendshapeRig: %d AU shape rows, %d of %d vertices move",
                  len(rows), len(moving), n_tot)

    # -- Rig API ----------------------------------------------------------------------------------
    @property
    def supported(self) -> tuple[str, ...]:
        return self._supported

    def _sides(self, aus: Mapping[str, float]) -> dict[str, tuple[float, float]]:
        c = self.check(aus)
        moved: dict[str, float] = {}
        for code, v in c.items():
            side = self._bilateral_side.get(code)
            key = code + side if side else code
            moved[key] = moved.get(key, 0.0) + v
        return split_sides(moved)

    def shape_deltas(self, code: str) -> dict[str, np.ndarray]:
        """The shape part of AU ``code`` at intensity 1: offsets (N_obj, 3) per object in the
        rig's own (rest or bind) space, without eye turns or head motion; {} for AUs with
        no shapes (morph targets of an export)."""
        c = parse_au(code)
        b = base_code(c)
        row = self._row.get(b)
        if row is None:
            return {}
        side = c[4:] or self._bilateral_side.get(b, "")
        return self._row_deltas([r for r, s in ((row, "L"), (row + 1, "R")) if side in ("", s)])

    def release_deltas(self) -> dict[str, np.ndarray]:
        """The ``release`` shapes at weight 1 per object, like :meth:`shape_deltas`; {} if the
        table has none."""
        return self._row_deltas([self.delta_matrix.shape[0] - 1]) if self.release else {}

    def release_weights(self, values: np.ndarray, channels: Sequence[str]) -> np.ndarray:
        """The ``release`` weight per frame of ``values`` (T, K) over ``channels``."""
        x, _ = self._rows_of(np.asarray(values, np.float32), list(self.check(
            dict.fromkeys(channels, 0.0))))
        return x[:, -1] if self.release else np.zeros(len(x), np.float32)

    def _release(self, x: np.ndarray) -> np.ndarray:
        """Release weights from per-row AU values ``x`` (T, rows)."""
        codes, full = self.release
        cols = [r + k for c in codes if (r := self._row.get(c)) is not None for k in (0, 1)]
        v = x[:, cols].max(1) if cols else np.zeros(len(x), np.float32)
        return _smoothstep(v / np.float32(full)).astype(np.float32)

    def _row_deltas(self, rows: list[int]) -> dict[str, np.ndarray]:
        d = self.delta_matrix[rows].sum(0)
        flat = np.zeros(len(self._rest) * 3, np.float32)
        for a, e, col in self._segments:
            flat[a:e] = d[col:col + e - a]
        full = flat.reshape(-1, 3)
        return {n: full[s] for n, s in self._slices.items()}

    def deform(self, aus: Mapping[str, float]) -> Positions:
        """Positions per object name, each (N_obj, 3) float32, for AU intensities in [0, 1]."""
        sides = self._sides(aus)
        out = self._rest.copy()
        idx, val = [], []
        for code, (l, r) in sides.items():
            row = self._row.get(code)
            if row is not None:
                if l:
                    idx.append(row)
                    val.append(l)
                if r:
                    idx.append(row + 1)
                    val.append(r)
        if self.release:
            x = np.zeros((1, self.delta_matrix.shape[0]), np.float32)
            x[0, idx] = val
            if (w := float(self._release(x)[0])) > 0:
                idx.append(len(x[0]) - 1)
                val.append(w)
        if idx:
            dm = self.delta_matrix
            d = dm[idx[0]] * np.float32(val[0])
            for i, v in zip(idx[1:], val[1:], strict=True):
                d += dm[i] * np.float32(v)
            flat = out.reshape(-1)
            for a, b, c in self._segments:
                flat[a:b] += d[c:c + b - a]
        eye_rv = np.zeros(3)
        head_rv = np.zeros(3)
        head_t = np.zeros(3)
        for code, (l, r) in sides.items():
            v = max(l, r)
            if code in self._eye_rot:
                eye_rv += v * self._eye_rot[code]
            if code in self._head_rot:
                head_rv += v * self._head_rot[code]
            if code in self._head_tr:
                head_t += v * self._head_tr[code]
        if eye_rv.any():
            self._apply_eyes(out[None], eye_rv[None])
        chk = self.check(aus) if self.body_channels else {}
        body = np.array([[chk.get(c, 0.0) for c in self.body_channels]], np.float64)
        self._move(out[None], head_rv[None], head_t[None], body)
        return {n: out[s] for n, s in self._slices.items()}

    #: body channels (``body.breath`` …) this rig moves; values reach :meth:`_move`
    body_channels: tuple[str, ...] = ()

    def _move(self, buf: np.ndarray, rv: np.ndarray, tr: np.ndarray,
              body: np.ndarray | None = None) -> None:
        """Head motion, applied last to all objects in place: buf (T, N, 3), head rotation
        vectors rv (T, 3), translations tr (T, 3) and body channel values (T, B) in the
        order of :attr:`body_channels`. Rigs with a skeleton override this."""
        if np.any(rv) or np.any(tr):
            self._apply_head(buf, rv, tr)

    def _apply_eyes(self, buf: np.ndarray, rv: np.ndarray) -> None:
        """In place on buf (T, N, 3): rotate each eyeball by rv (T, 3) about its pivot."""
        rot_t = np.ascontiguousarray(_rotmat(rv).transpose(0, 2, 1), dtype=np.float32)
        for name, piv in self._eyes:
            sl = self._slices[name]
            pv = piv.astype(np.float32)
            for t in range(len(buf)):
                x = buf[t, sl] @ rot_t[t]
                _add3(x, pv - pv @ rot_t[t])
                buf[t, sl] = x

    def _apply_head(self, buf: np.ndarray, rv: np.ndarray, tr: np.ndarray) -> None:
        """In place on buf (T, N, 3): rotate by rv (T, 3) about neck_pivot, translate by tr.

        Vertices with neck weight w < 1 rotate by w·angle about the same axis and translate by
        w·tr, so the neck bends smoothly instead of tearing.
        """
        c = self._neck_pivot.astype(np.float32)
        rv = np.asarray(rv, np.float32)
        tr = np.asarray(tr, np.float32)
        rot_t = np.ascontiguousarray(_rotmat(rv).transpose(0, 2, 1), dtype=np.float32)
        p, wp = self._partial, self._wp
        th = np.sqrt((rv * rv).sum(1))
        axes = rv / np.where(th > 1e-12, th, 1.0)[:, None]
        for t in range(len(buf)):
            b = buf[t]
            q = b[p] - c  # (P, 3) bending vertices, before the rigid rotation
            x = b @ rot_t[t]
            _add3(x, c - c @ rot_t[t] + tr[t])
            b[:] = x
            if len(p):
                ang = th[t] * wp
                co, si = np.cos(ang), np.sin(ang)
                kx, ky, kz = (float(a) for a in axes[t])
                qx, qy, qz = q[:, 0], q[:, 1], q[:, 2]
                kd = (qx * kx + qy * ky + qz * kz) * (1 - co)
                q = np.stack([
                    qx * co + (ky * qz - kz * qy) * si + kx * kd,
                    qy * co + (kz * qx - kx * qz) * si + ky * kd,
                    qz * co + (kx * qy - ky * qx) * si + kz * kd,
                ], axis=1)
                q += wp[:, None] * tr[t]
                _add3(q, c)
                b[p] = q

    def _rows_of(self, vals: np.ndarray, chans: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """Per frame of ``vals`` (T, K) over checked ``chans``: the weight of every delta row
        (T, rows; the release's last), and the channels' eye rotation, head rotation and head
        translation vectors (3, K, 3)."""
        sel = np.zeros((len(chans), self.delta_matrix.shape[0]), np.float32)
        motion = np.zeros((3, len(chans), 3))
        for k, c in enumerate(chans):
            b = base_code(c)
            side = c[4:] or self._bilateral_side.get(b, "")
            row = self._row.get(b)
            if row is not None:
                if side in ("", "L"):
                    sel[k, row] = 1
                if side in ("", "R"):
                    sel[k, row + 1] = 1
            for m, table in zip(motion, (self._eye_rot, self._head_rot, self._head_tr),
                                strict=True):
                m[k] = table.get(b, 0.0)
        x = np.minimum(vals @ sel, 1.0)  # per-side sums clipped, as split_sides does
        if self.release:
            x[:, -1] = self._release(x)
        return x, motion

    def deform_batch(self, values: np.ndarray, channels: Sequence[str]) -> dict[str, np.ndarray]:
        """Positions for T frames: values (T, K) in [0, 1] over ``channels`` → name → (T, N, 3).

        The shape part is one matrix product over the vertices any shape moves.
        """
        vals = np.asarray(values, np.float32)
        if vals.ndim != 2 or vals.shape[1] != len(channels):
            raise ParameterError(f"values must have shape (T, {len(channels)}), got {vals.shape}")
        if vals.size and (not np.all(np.isfinite(vals)) or vals.min() < 0 or vals.max() > 1):
            raise ParameterError("values must be finite and within [0, 1]")
        chans = list(self.check(dict.fromkeys(channels, 0.0)))
        if len(chans) != len(channels):
            raise ParameterError("channels must be unique")
        x, (eye, head, trans) = self._rows_of(vals, chans)
        used = np.flatnonzero(np.any(x > 0, axis=0))
        dm = self.delta_matrix[used]
        eye_rv, head_rv, head_tr = vals @ eye, vals @ head, vals @ trans
        body = np.zeros((len(vals), len(self.body_channels)))
        for j, c in enumerate(self.body_channels):
            if c in chans:
                body[:, j] = vals[:, chans.index(c)]
        t_all = len(vals)
        out = np.empty((t_all, len(self._rest), 3), np.float32)
        for t0 in range(0, t_all, _CHUNK):
            t1 = min(t0 + _CHUNK, t_all)
            buf = out[t0:t1]
            buf[:] = self._rest
            if len(used):
                d = x[t0:t1, used] @ dm  # (t, 3M): the whole shape part in one product
                flat = buf.reshape(t1 - t0, -1)
                for a, b, c in self._segments:
                    flat[:, a:b] += d[:, c:c + b - a]
            if np.any(eye_rv[t0:t1]):
                self._apply_eyes(buf, eye_rv[t0:t1])
            self._move(buf, head_rv[t0:t1], head_tr[t0:t1], body[t0:t1])
        return {n: out[:, s] for n, s in self._slices.items()}
