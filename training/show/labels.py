"""A body's parts named on a picture: `impactnet show --labels BODY` (issue #33).

The part names of the generated bodies (``casting_top_fl``, ``head_ar/...``) are what a compound
answer's contacts name; this draws the body from above and from the side, each part group
shaded, and writes its group's name next to it, so that a reader can find the part an answer
names. Corners: ``f``/``a`` fore and aft (+x, -x), ``l``/``r`` left and right (+y, -y).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.parts import bounds
from impactnet.models.scene_bodies import part_group

#: Groups drawn but not named (the body part itself would crowd the picture).
UNLABELLED = ("body", "frame")
#: Width (m) of the zoomed side view at the body's +x end.
ZOOM_M = 1.2


def group_bounds(parts) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each part group's bounds (lo, hi), body frame, metres, in the parts' order."""
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for part in parts:
        lo, hi = bounds(part)
        group = part_group(part.name)
        if group in out:
            lo, hi = np.minimum(out[group][0], lo), np.maximum(out[group][1], hi)
        out[group] = (lo, hi)
    return out


def _visible_from_above(groups: dict) -> list[str]:
    """The groups a view from above shows: of overlapping footprints, the highest."""
    shown = []
    for group, (lo, hi) in groups.items():
        covered = any(np.all(lo[:2] < h[:2]) and np.all(l[:2] < hi[:2]) and h[2] > hi[2]
                      for other, (l, h) in groups.items()
                      if other != group and other not in UNLABELLED)
        if group not in UNLABELLED and not covered:
            shown.append(group)
    return shown


def _draw(ax, groups: dict, u: int, v: int, named: list[str], title: str,
          window=None) -> None:
    """Rectangles of every group's bounds on axes (u, v) of the body frame, ``named`` ones
    labelled in a column beside the picture's middle, ``window`` (u range) zoomed into."""
    from matplotlib.patches import Rectangle

    for k, (group, (lo, hi)) in enumerate(groups.items()):
        colour = (0.8, 0.8, 0.85) if group in UNLABELLED else (0.85, 0.35 + 0.1 * (k % 4),
                                                               0.2, 0.8)
        ax.add_patch(Rectangle((lo[u], lo[v]), hi[u] - lo[u], hi[v] - lo[v],
                               facecolor=colour, edgecolor="black", linewidth=0.4))
    span = [min(lo[u] for lo, _ in groups.values()), max(hi[u] for _, hi in groups.values())]
    if window is not None:
        span = window
    text_u = span[0] + 0.55 * (span[1] - span[0])
    named = sorted(named, key=lambda g: 0.5 * (groups[g][0][v] + groups[g][1][v]))
    lows = [groups[g][0][v] for g in groups]
    highs = [groups[g][1][v] for g in groups]
    for k, group in enumerate(named):
        lo, hi = groups[group]
        text_v = min(lows) + (k + 0.5) * (max(highs) - min(lows)) / max(len(named), 1)
        ax.annotate(group, (0.5 * (lo[u] + hi[u]), 0.5 * (lo[v] + hi[v])),
                    xytext=(text_u, text_v), fontsize=7, ha="left", va="center",
                    arrowprops={"arrowstyle": "-", "linewidth": 0.4})
    ax.set_xlim(span[0] - 0.05 * (span[1] - span[0]), span[1] + 0.05 * (span[1] - span[0]))
    ax.set_ylim(min(lows) - 0.1, max(highs) + 0.1)
    ax.set_title(title, fontsize=9)


def write_labels(path, name: str, parts, detail: str) -> int:
    """Draw body ``name``'s parts (module docstring) into the PNG ``path``: from above, every
    group seen from above named; from the side, zoomed onto the +x end, the +y side's groups
    named. Returns the number of groups drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = group_bounds(parts)
    top = max(hi[0] for _, hi in groups.values())
    fig, (above, side) = plt.subplots(2, 1, figsize=(11, 7), dpi=120)
    _draw(above, groups, 0, 1, _visible_from_above(groups),
          "from above (x right, y up): the groups seen from above")
    near_end = [g for g, (lo, hi) in groups.items()
                if g not in UNLABELLED and hi[0] > top - ZOOM_M and lo[1] + hi[1] >= 0.0]
    _draw(side, groups, 0, 2, near_end, "from the side (x right, z up), the +x end, the +y "
          "(l) side's groups", window=(top - ZOOM_M, top))
    fig.suptitle(f"{name} ({detail}): {len(parts)} parts in {len(groups)} groups; "
                 "corners f/a = +x/-x, l/r = +y/-y", fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return len(groups)
