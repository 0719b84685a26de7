"""Accuracy of fitted fields, seed Table 4.3 style (n, d, d_max, e, e_max in mm): CSV, Markdown."""

from __future__ import annotations

import csv
import io
import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

log = logging.getLogger(__name__)


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
