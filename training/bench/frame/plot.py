"""The scaling figure of ``impactnet bench frame``: time per frame against bodies, log-log,
the whole frame per variant and the broadphase alone per yard layout, with the broadphase's
fit, each whole-frame point labelled with the pairs it kept."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def _fit_curve(n: np.ndarray, fitted: dict, x: np.ndarray) -> np.ndarray:
    """The fit's milliseconds at ``n`` bodies with ``x`` of its column."""
    return 1e-3 * fitted["c_us"] + 1e-6 * (fitted["a_ns"] * n * np.log2(n)
                                           + fitted["b_ns"] * x)


def plot_scaling(scaling: dict, path: Path, command: str) -> Path:
    """Write the figure (PNG) to ``path``; returns it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.0, 5.6))
    frames = scaling["frames"]
    for variant, marker in (("boxes", "o"), ("detail 2", "s")):
        rows = [r for r in frames if variant in r]
        if not rows:
            continue
        n = np.array([r["bodies"] for r in rows], float)
        ms = np.array([r[variant]["ms"] for r in rows])
        ax.plot(n, ms, marker=marker, lw=2, label=f"whole frame, {variant}")
        for x, y, r in zip(n, ms, rows):
            ax.annotate(f"{r[variant]['kept']:,} pairs", (x, y), textcoords="offset points",
                        xytext=(6, -12 if variant == "boxes" else 6), fontsize=7)
    for layout, style in (("square", "-"), ("block", "--")):
        series = scaling["broadphase"][layout]
        points = series["points"]
        n = np.array([p["bodies"] for p in points], float)
        ms = np.array([p["ms"] for p in points])
        ax.plot(n, ms, style, marker=".", color="tab:green" if layout == "square" else
                "tab:olive", label=f"broadphase alone, {layout} yards")
        fitted = series["fit_candidates"]
        x = np.array([p["candidates"] for p in points], float)
        ax.plot(n, _fit_curve(n, fitted, x), ":", color="grey", lw=1)
    reference = np.array([10.0, 3e4])
    ax.plot(reference, 1e-4 * reference * np.log2(reference) / np.log2(1e3), ":", color="k",
            lw=0.8, label="n log n (slope guide)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("bodies in the frame (every body free)")
    ax.set_ylabel("median wall time per frame (ms)")
    ax.set_title("A frame in one call: answer_frame (exact) and its broadphase", fontsize=11)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.text(0.01, 0.01, f"{command}; dotted grey: the broadphase's fit "
             "c + a n log2 n + b (candidates walked)", fontsize=7, color="grey")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
