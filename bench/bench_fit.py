"""Benchmark: fitting seed-002 AU fields to the ICT shapes (seed and rich families).

    MIMIKA_ICT_DIR=… python bench/bench_fit.py [--all] [--au AU12 …]

Prints the fit time per AU (a few representative AUs by default; ``--all``: every fittable AU
and the whole run) for both families, with the accuracy (mean e/d_max on held-out vertices).
Budget per field: Ψ 6000 and φ 3000 Nelder–Mead evaluations on ≤ 1500 moving + ≤ 500 still
vertices (FitOptions defaults).
"""

from __future__ import annotations

import argparse
import sys
import time

from _common import ict_available, report, single_core

single_core()

from mimika.face.fitting import FitOptions, fit_ict

DEFAULT_AUS = ["AU01", "AU12", "AU27", "AU45"]


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--all", action="store_true", help="every fittable AU (minutes)")
    p.add_argument("--au", action="append")
    a = p.parse_args()
    if not ict_available():
        print("bench_fit: MIMIKA_ICT_DIR not set; skipped", file=sys.stderr)
        return 0
    aus = None if a.all else (a.au or DEFAULT_AUS)
    fit_ict(aus=["AU02"], options=FitOptions(psi_evals=50, phi_evals=50))  # warm caches
    for family in ("seed", "rich"):
        t0 = time.perf_counter()
        res = fit_ict(aus=aus, options=FitOptions(family=family))
        total = time.perf_counter() - t0
        for r in res.accuracy:
            if r.obj == "face":
                report(f"fit {family:<4} {r.code} (e/d_max {100 * r.e_rel:4.1f} %)", r.fit_s, "s")
        n = sum(1 for r in res.accuracy if r.obj == "face")
        report(f"fit {family:<4} {n} AUs total (mean e/d_max {100 * res.mean_e_rel:4.1f} %)",
               total, "s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
