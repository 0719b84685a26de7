"""Plot how a mood changes the newsreader's behaviour layers (docs/img/mood.png).

The same spoken paragraph (espeak-ng), the same seed, two moods: per layer the AU curves that
mood changes — head nods (AU53/AU54 pitch), brow raises (AU01+AU02), the smile (AU12) and
blinks (AU45) — with counts of nods and brow raises in the legend.

    .venv/bin/python bench/mood_plot.py [--moods happy,depressed] [-o docs/img/mood.png]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import numpy as np

from mimika.behaviour.mood import mood_factors
from mimika.behaviour.speaking import speaking_behaviour
from mimika.speech.tts import synthesize

TEXT = ("Good evening. The city council met on Monday to discuss the new budget for public "
        "transport. Buses will run more often, and a new tram line is planned for the north. "
        "Critics say the plan is too expensive. Is it worth the money? The vote is next week. "
        "Thank you for watching, and good night.")


def bumps(x: np.ndarray, thr: float) -> int:
    up = (x[1:] > thr) & (x[:-1] <= thr)
    return int(up.sum())


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ap = argparse.ArgumentParser()
    ap.add_argument("--moods", default="happy,depressed")
    ap.add_argument("-o", "--output", default=str(Path(__file__).resolve().parents[1] / "docs"
                                                   / "img" / "mood.png"))
    args = ap.parse_args()
    moods = args.moods.split(",")
    u = synthesize(TEXT)
    fps = 25
    rows = (("head pitch (AU54 − AU53)", lambda m: m["AU54"] - m["AU53"], 0.02),
            ("brows (AU01 + AU02)", lambda m: m["AU01"] + m["AU02"], 0.1),
            ("smile (AU12)", lambda m: m["AU12"], None),
            ("blink (AU45)", lambda m: m["AU45"], 0.5))
    fig, axes = plt.subplots(len(rows), 1, figsize=(10, 7), sharex=True)
    for mood, colour in zip(moods, ("tab:orange", "tab:blue", "tab:green"), strict=False):
        merged, _ = speaking_behaviour(u, fps=fps, mood=mood, seed=7)
        t = np.arange(merged.n_frames) / fps
        rate, strength, dur = mood_factors(mood)
        for ax, (title, f, thr) in zip(axes, rows, strict=True):
            y = f(merged)
            lab = f"{mood} (rate ×{rate:.2f}, strength ×{strength:.1f}, length ×{dur:.2f})"
            if thr is not None:
                lab += f": {bumps(np.abs(y) if 'head' in title else y, thr)} events"
            ax.plot(t, y, color=colour, lw=1.2, label=lab)
            ax.set_ylabel(title, fontsize=8)
    for ax in axes:
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle("The same bulletin and seed, two moods: how often and how strongly the "
                 "layers act", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
