"""The figures of `impactnet evaluate` (matplotlib, Agg backend; PNG files).

* ``error_cdf.png``: the pooled empirical CDF of the normal error (degrees) and the point
  error (% of e) of each predictor, on the rows both it and the exact solver call colliding.
* ``boundary.png``: median and p99 of both errors against the distance to the nearest region
  boundary (:mod:`impactnet.training.evaluate.data`), and the share of rows and the region error
  rate per distance bin.
* ``confusion.png``: the contact-type confusion matrix of each predictor that names types,
  row-normalised (exact type per row), with the row counts written in the cells.

The exact solver (the reference: error 0 everywhere) is left out of the plots. Errors of 0 cannot be
drawn on log axes; everything below :data:`impactnet.training.bench.plots.ERROR_FLOOR` is drawn at
it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from impactnet.models.contacts import CONTACT_TYPES
from impactnet.training.bench.plots import ERROR_FLOOR, _pyplot, _save

#: Line colours per predictor.
COLOURS = {"exact": "black", "single": "tab:orange", "committee": "tab:blue",
           "auto": "tab:green"}


def _floored(values) -> np.ndarray:
    """Values as floats with None as NaN and everything below ERROR_FLOOR raised to it."""
    v = np.array([np.nan if x is None else x for x in values], dtype=np.float64)
    return np.where(v < ERROR_FLOOR, ERROR_FLOOR, v)


def error_cdf(results: dict, path: Path) -> Path:
    """``error_cdf.png`` (module docstring); returns its path."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for name, cdf in results["pooled"]["cdf"].items():
        if name == "exact":
            continue
        for ax, key in ((axes[0], "normal_deg"), (axes[1], "point_pct")):
            if cdf[key]["value"]:
                ax.plot(_floored(cdf[key]["value"]), cdf[key]["p"],
                        color=COLOURS.get(name, "gray"), label=name)
    for ax, label in ((axes[0], "normal error, degrees"),
                      (axes[1], "point error, % of the smaller body's shortest edge")):
        ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("share of rows (both say contact)")
        ax.set_title(f"pooled over the scene; errors <= {ERROR_FLOOR:g} drawn at "
                     f"{ERROR_FLOOR:g}", fontsize=9)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=8)
    return _save(plt, fig, path)


def boundary(results: dict, path: Path) -> Path:
    """``boundary.png`` (module docstring); returns its path."""
    plt = _pyplot()
    bins = results["pooled"]["boundary"]["distance"]
    x = np.arange(len(bins["labels"]))
    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    for name, figures in bins["predictors"].items():
        if name == "exact":
            continue
        colour = COLOURS.get(name, "gray")
        for ax, key in ((axes[0], "normal_deg"), (axes[1], "point_pct")):
            ax.plot(x, _floored(figures[f"{key}_median"]), "o-", ms=3, color=colour,
                    label=f"{name} median")
            ax.plot(x, _floored(figures[f"{key}_p99"]), "s:", ms=3, mfc="none", color=colour,
                    label=f"{name} p99")
        if any(v is not None for v in figures["region_error_rate"]):
            rate = [np.nan if v is None else v for v in figures["region_error_rate"]]
            axes[2].plot(x, rate, "o-", ms=3, color=colour, label=f"{name} region error rate")
    axes[2].bar(x, bins["share"], color="lightgray", label="share of contact rows")
    for ax, label in ((axes[0], "normal error, degrees"), (axes[1], "point error, % of e"),
                      (axes[2], "share")):
        if ax is not axes[2]:
            ax.set_yscale("log")
        ax.set_xticks(x, bins["labels"], rotation=35, ha="right", fontsize=7)
        ax.set_xlabel("distance to the nearest region boundary, fraction of e")
        ax.set_ylabel(label)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=7)
    axes[0].set_title("error against the boundary distance (pooled)", fontsize=9)
    return _save(plt, fig, path)


def confusion(results: dict, path: Path) -> Path | None:
    """``confusion.png`` (module docstring); None (nothing written) without a typed predictor."""
    matrices = {name: np.asarray(m) for name, m in results["pooled"]["type_confusion"].items()
                if m is not None and name != "exact"}
    if not matrices:
        return None
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(matrices), figsize=(6.2 * len(matrices), 5.4),
                             squeeze=False)
    for ax, (name, counts) in zip(axes[0], matrices.items()):
        share = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
        ax.imshow(share, cmap="Blues", vmin=0.0, vmax=1.0)
        for i, j in zip(*np.nonzero(counts)):
            ax.text(j, i, f"{counts[i, j]}", ha="center", va="center", fontsize=6,
                    color="white" if share[i, j] > 0.5 else "black")
        ax.set_xticks(range(len(CONTACT_TYPES)), CONTACT_TYPES, rotation=40, ha="right",
                      fontsize=7)
        ax.set_yticks(range(len(CONTACT_TYPES)), CONTACT_TYPES, fontsize=7)
        ax.set_xlabel(f"{name}: predicted type")
        ax.set_ylabel("exact type")
        ax.set_title(f"{name}: contact types (row share, counts)", fontsize=9)
    return _save(plt, fig, path)


def write_all(results: dict, out: Path) -> list[Path]:
    """Every figure into ``out``; returns the paths written."""
    paths = [error_cdf(results, out / "error_cdf.png"), boundary(results, out / "boundary.png")]
    matrix = confusion(results, out / "confusion.png")
    return paths + ([matrix] if matrix is not None else [])
