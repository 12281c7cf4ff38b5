"""The benchmark's figures (matplotlib, Agg backend; PNG files).

* ``pareto.png``: p99 normal and point errors against time per pair, log scales, one row per
  pose set. Hollow markers: one pair per call (N = 1); filled: per pair in a batch / loop at the
  N measured. The exact solver's error is 0 by definition; it is drawn at :data:`ERROR_FLOOR`.
* ``polygon_grid.png``: the polygon method against n: time per pair, point error with the
  paper's bound sqrt(2)/n, normal error.
* ``figure2_tilt.png``: median errors on the Figure 2 set against the tilt, per method.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

#: Errors below this are drawn at it (log axes cannot show 0), degrees and per cent: the
#: exact solver (0 by definition) and anything exact to round-off (1e-4 % of a 2.4 m edge is
#: 2.4 micrometres).
ERROR_FLOOR = 1e-4
#: Colours by method family.
COLOURS = {"exact": "black", "fcl": "tab:orange", "polygon": "tab:blue", "learned": "tab:green",
           "other": "tab:red"}
#: Polygon grids drawn against the tilt (those of the sweep that are present).
TILT_GRIDS = (4, 16, 64)
DPI = 110


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _floor(x):
    return ERROR_FLOOR if x is None or x < ERROR_FLOOR else x


def _pareto_panel(ax, rows, key: str, label: str) -> None:
    ok = [r for r in rows if r["status"] == "ok"]
    for r in ok:
        y = _floor(r["errors"][key])
        colour = COLOURS.get(r["family"], "gray")
        ax.plot([r["us_n1"], r["us_per_pair"]], [y, y], color=colour, lw=0.6, alpha=0.5)
        ax.scatter([r["us_n1"]], [y], facecolors="none", edgecolors=colour, s=30)
        ax.scatter([r["us_per_pair"]], [y], color=colour, s=30)
        if r["family"] != "polygon" or r["info"].get("grid") in (1, 64):
            ax.annotate(r["method"], (r["us_per_pair"], y), fontsize=7,
                        xytext=(3, 3), textcoords="offset points")
    polygon = sorted((r for r in ok if r["family"] == "polygon"), key=lambda r: r["info"]["grid"])
    if polygon:
        ax.plot([r["us_per_pair"] for r in polygon], [_floor(r["errors"][key]) for r in polygon],
                color=COLOURS["polygon"], lw=1.0)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("µs per pair (hollow: N = 1, one call; filled: batch / loop)")
    ax.set_ylabel(label)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)


def pareto(results: dict, path: Path) -> Path:
    plt = _pyplot()
    sets = list(results["pose_sets"])
    fig, axes = plt.subplots(len(sets), 2, figsize=(13, 5 * len(sets)), squeeze=False)
    for i, name in enumerate(sets):
        rows = [r for r in results["rows"] if r["pose_set"] == name]
        _pareto_panel(axes[i, 0], rows, "normal_deg_p99", "normal error p99, degrees")
        _pareto_panel(axes[i, 1], rows, "point_pct_p99", "point error p99, % of shortest edge")
        for ax in axes[i]:
            ax.set_title(f"{name}: p99 error against time per pair", fontsize=10)
    fig.suptitle(f"Errors <= {ERROR_FLOOR:g} (the exact solver's 0 among them) are drawn at "
                 f"{ERROR_FLOOR:g}; log scales", fontsize=10)
    return _save(plt, fig, path)


def _save(plt, fig, path: Path) -> Path:
    """Lay out, write as PNG and close a figure; returns its path."""
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def polygon_grid(results: dict, path: Path) -> Path:
    plt = _pyplot()
    by_n = results["paper_estimate"]["by_n"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    styles = {"scene": "tab:blue", "figure2": "tab:red"}
    for name in dict.fromkeys(b["pose_set"] for b in by_n):
        mine = [b for b in by_n if b["pose_set"] == name]
        n = [b["n"] for b in mine]
        colour = styles.get(name, "gray")
        axes[0].plot(n, [b["us_per_pair"] for b in mine], "o-", color=colour,
                     label=f"{name}: loop, per pair")
        axes[0].plot(n, [b["us_n1"] for b in mine], "o--", color=colour, mfc="none",
                     label=f"{name}: N = 1 median")
        for ax, key, unit in ((axes[1], "point_pct", ""), (axes[2], "normal_deg", "")):
            ax.plot(n, [_floor(b[f"{key}_median"]) for b in mine], "o-", color=colour,
                    label=f"{name} median{unit}")
            ax.plot(n, [_floor(b[f"{key}_p99"]) for b in mine], "s--", color=colour, mfc="none",
                    label=f"{name} p99")
    grid = np.geomspace(1, 64, 50)
    axes[1].plot(grid, 100 * np.sqrt(2) / grid, "k:", label="paper: √2/n (cube)")
    for ax, title, label in ((axes[0], "time", "µs per pair"),
                             (axes[1], "point error", "% of the shortest edge"),
                             (axes[2], "normal error", "degrees")):
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("n (squares per face edge)")
        ax.set_ylabel(label)
        ax.set_title(f"polygon method: {title} against n", fontsize=10)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=7)
    return _save(plt, fig, path)


def figure2_tilt(results: dict, path: Path) -> Path:
    plt = _pyplot()
    rows = [r for r in results["rows"] if r["pose_set"] == "figure2" and r["status"] == "ok"
            and r["family"] != "exact" and "by_tilt" in r["info"]
            and (r["family"] != "polygon" or r["info"]["grid"] in TILT_GRIDS)]
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6))
    for k, r in enumerate(rows):
        t = r["info"]["by_tilt"]
        colour = f"C{k % 10}"
        for ax, key in ((axes[0], "normal_deg"), (axes[1], "point_pct")):
            ax.plot(t["group"], [_floor(v) for v in t[f"{key}_median"]], "o-", ms=3,
                    color=colour, label=r["method"])
            ax.plot(t["group"], [_floor(v) for v in t[f"{key}_p99"]], ":", lw=1,
                    color=colour)
    for ax, label in ((axes[0], "normal error, degrees (solid: median, dotted: p99)"),
                      (axes[1], "point error, % of the edge (solid: median, dotted: p99)")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("tilt of B's face against A's, rad")
        ax.set_ylabel(label)
        ax.set_title(f"Figure 2 hard case: error against the tilt (exact = 0; errors <= "
                     f"{ERROR_FLOOR:g} drawn at the bottom)", fontsize=9)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=7)
    return _save(plt, fig, path)


def write_all(results: dict, out: Path) -> list[Path]:
    """Every figure into ``out``; returns the paths written."""
    paths = [pareto(results, out / "pareto.png")]
    if results["paper_estimate"]["by_n"]:
        paths.append(polygon_grid(results, out / "polygon_grid.png"))
    if "figure2" in results["pose_sets"]:
        paths.append(figure2_tilt(results, out / "figure2_tilt.png"))
    return paths
