"""An independent centre-of-pressure reference: a midpoint grid over the reference face.

docs/design.md defines ``point`` as the centre of pressure of the contact region under a pressure
proportional to the local penetration depth. This module computes it by brute force, without
the solver's manifold or clipping code (it imports nothing from ``models``):

1. Reference face (:func:`impactnet.training.bench.accuracy.cop_frame.reference_faces`): of A's six
   faces and B's six faces, the one whose outward normal is best aligned with a given contact normal
   ``n`` (A's face with ``+n``, B's with ``-n``; A wins exact ties). Its box is the reference box,
   the other the incident box.
2. Grid rectangle (:func:`impactnet.training.bench.accuracy.cop_frame.grid_frame`): the incident
   box's vertices beyond the reference plane and its edges' crossings with the plane span the
   footprint (the projection of its part beyond the plane); the grid takes the axes of their
   minimum-area bounding rectangle and the extents of the footprint clipped to the reference face
   (:func:`impactnet.training.bench.accuracy.cop_frame.clipped_points`). A footprint of a square
   millimetre is resolved as finely as one of square metres, a thin diagonal sliver as finely
   as a square.
3. Depth per grid point (:func:`impactnet.training.bench.accuracy.cop_frame.depth_at`): the line
   through the cell centre ``y`` (on the reference plane) along the face's outward normal meets the
   incident box in ``[s_in, s_out]`` (slab method); ``d(y) = -s_in``, how far the incident
   box's surface that faces the reference face lies beyond the plane (into the reference box);
   0 where the line misses the box or ``y`` lies outside the reference face (its side planes
   are two more slabs).
4. Centre of pressure, pressure ``max(d, 0)``, equal cells (midpoint rule): the ``d``-weighted
   mean of ``y - n_ref d(y) / 2`` (half the local depth below the plane), i.e. tangentially
   ``sum(d y) / sum(d)`` and ``sum(d^2) / (2 sum(d))`` below the plane.

Accuracy. ``d`` is continuous and piecewise linear inside the footprint, where the midpoint rule
is exact up to the kinks (error ~ cell^2); at the footprint's edge it may jump to 0 (an
incident face perpendicular to the reference face), and that edge may run parallel to the
grid (stacks whose edges line up), where a square sub-grid would locate it only to its own
spacing. So the cells on the edge (:func:`_boundary_cells`) are resampled with a Fibonacci
lattice (:func:`fibonacci_lattice`), whose points are distinct along both axes. Measured against
a G = 384 / 89-point grid on ~740 face contacts of 2 m cubes (uniform, near-parallel faces and
near-parallel edges; ``tests/training/bench/test_centre_of_pressure_reference.py`` re-measures it):

=========  ===================================  ==================================
grid       worst error / footprint's long side  worst error, % of the 2 m edge
=========  ===================================  ==================================
32 / 21    2.0e-3                               0.14
64 / 55    7.0e-4                               0.031
128 / 55   3.5e-4                               0.015
=========  ===================================  ==================================

``CentreOfPressure.error`` (the distance to the answer on a grid of half as many cells a side)
is a per-row indication only: where an edge of the footprint runs along the grid, both grids
can share most of their error; errors up to 20x the indication were seen.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.training.bench.accuracy.cop_frame import (
    clipped_points,
    constraints,
    depth_at,
    grid_frame,
    reference_faces,
    reference_frame,
    support_points,
)

__all__ = ["DEFAULT_GRID", "DEFAULT_REFINE", "CentreOfPressure", "centre_of_pressure",
           "fibonacci_lattice", "reference_faces"]

#: Default cells per side of the grid (see the accuracy table above).
DEFAULT_GRID = 32
#: Grid points handled per NumPy block (rows x G^2), to bound memory (8 bytes x ~30 arrays).
BLOCK_POINTS = 1 << 19
#: Default sub-samples of a cell on the footprint's edge (where ``d`` may jump to 0): the
#: points of a Fibonacci lattice (:func:`fibonacci_lattice`), so a Fibonacci number.
DEFAULT_REFINE = 21
#: The reference face's corners as signs along u and w, in the order of
#: :func:`impactnet.training.bench.accuracy.cop_frame.clipped_points`.
_CORNER_U, _CORNER_W = np.array([1.0, -1.0, -1.0, 1.0]), np.array([1.0, 1.0, -1.0, -1.0])


@dataclass
class CentreOfPressure:
    """The grid reference for N pairs (world frame, metres).

    Attributes
    ----------
    point : ndarray, shape (n, 3)
        Centre of pressure on the mid-surface; NaN where the footprint is empty.
    error : ndarray, shape (n,)
        Indicated discretisation error of ``point``: its distance to the answer on a grid of
        half as many cells a side (metres; see the module docstring); NaN where empty or not
        asked for.
    ref_is_b : ndarray of bool, shape (n,)
        The reference face is B's.
    ref_axis : ndarray of int, shape (n,)
        Reference face axis (0-2) in its box's frame.
    ref_sign : ndarray, shape (n,)
        +-1: the face's side along that axis.
    volume : ndarray, shape (n,)
        Integral of ``max(d, 0)`` over the reference face (m^3), on the G grid.
    footprint : ndarray, shape (n,)
        Larger side of the grid's rectangle (metres); 0 where empty.
    """

    point: np.ndarray
    error: np.ndarray
    ref_is_b: np.ndarray
    ref_axis: np.ndarray
    ref_sign: np.ndarray
    volume: np.ndarray
    footprint: np.ndarray

    @property
    def empty(self) -> np.ndarray:
        """(n,) bool: no part of the incident box lies beyond the reference face."""
        return ~np.isfinite(self.point[:, 0])


def _boundary_cells(support: np.ndarray) -> np.ndarray:
    """Cells (m, G, G) that the footprint's edge may cross: those with an 8-neighbour on the
    other side, and the grid's outer ring (the footprint touches every side of its bounding
    rectangle, and an edge nearly parallel to a side can cross the ring between cell centres).
    """
    padded = np.pad(support, ((0, 0), (1, 1), (1, 1)), mode="edge")
    g1, g2 = support.shape[1:]
    flags = np.zeros_like(support)
    for di in (0, 1, 2):
        for dj in (0, 1, 2):
            flags |= padded[:, di:di + g1, dj:dj + g2] != support
    flags[:, [0, -1], :] = True
    flags[:, :, [0, -1]] = True
    return flags


def _moments(depth, a, b):
    """Sums of d, d a, d b and d^2 over the trailing two axes, (4, ...)."""
    axes = (-2, -1)
    return np.stack([depth.sum(axis=axes), (depth * a).sum(axis=axes),
                     (depth * b).sum(axis=axes), (depth * depth).sum(axis=axes)])


def fibonacci_lattice(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (in cells, within +-0.5) of a rank-1 Fibonacci lattice of ``count`` points.

    ``count`` is a Fibonacci number F_k; point i sits at ``((i + 1/2) / F_k, ((i F_(k-1) + s)
    mod F_k + 1/2) / F_k)``, the shift ``s`` (``2 s = F_(k-1) - 1 mod F_k``) making the set
    symmetric about the cell's centre, so that a straight edge through a cell is not biased to
    one side. Unlike a square sub-grid of the same size, the points take ``count`` distinct
    values along each axis: an edge of the footprint parallel to a grid line (a stack whose
    edges line up) is located to 1 / count of a cell instead of 1 / sqrt(count).
    """
    previous, current = 1, 1
    while current < count:
        previous, current = current, previous + current
    if current != count:
        raise ValueError(f"refine must be a Fibonacci number, got {count}")
    shift = (previous - 1) // 2 if previous % 2 else (previous - 1 + count) // 2
    k = np.arange(count)
    return (k + 0.5) / count - 0.5, ((k * previous + shift) % count + 0.5) / count - 0.5


def _grid_sums(coef, low, high, grid, refine):
    """Midpoint-rule sums of d, d a, d b, d^2 over each row's grid rectangle, (4, m).

    Cells on the footprint's edge, where ``d`` may jump, are resampled with a Fibonacci
    lattice of ``refine`` points. The sums count cells (multiply by the cell area for
    integrals).
    """
    m = coef.shape[-1]
    side = np.maximum(high - low, 0.0)  # (m, 2)
    frac = (np.arange(grid) + 0.5) / grid
    a = (low[:, 0, None] + side[:, 0, None] * frac)[:, :, None]  # (m, G, 1)
    b = (low[:, 1, None] + side[:, 1, None] * frac)[:, None, :]  # (m, 1, G)
    depth = depth_at(coef[..., None, None], a, b)
    sums = _moments(depth, a, b)
    row, i, j = np.nonzero(_boundary_cells(depth > 0.0))
    if row.size:
        off_a, off_b = fibonacci_lattice(refine)  # (N,) offsets within a cell, in cells
        sa = a[row, i, 0][:, None] + (side[row, 0] / grid)[:, None] * off_a  # (F, N)
        sb = b[row, 0, j][:, None] + (side[row, 1] / grid)[:, None] * off_b
        fine = _moments(depth_at(coef[:, :, row, None], sa, sb)[:, None, :], sa[:, None, :],
                        sb[:, None, :]) / len(off_a)
        cell = depth[row, i, j]
        coarse = np.stack([cell, cell * a[row, i, 0], cell * b[row, 0, j], cell * cell])
        for q in range(4):
            sums[q] += np.bincount(row, weights=fine[q] - coarse[q], minlength=m)
    return sums


def _local_point(sums, e1, e2, k, sign, half_ref):
    """Centre of pressure in the reference box's frame, (m, 3), from :func:`_grid_sums`."""
    m = sums.shape[1]
    rows = np.arange(m)
    with np.errstate(invalid="ignore", divide="ignore"):
        total = np.where(sums[0] > 0.0, sums[0], np.nan)
        a, b = sums[1] / total, sums[2] / total
        point = np.empty((m, 3))
        point[rows, k] = sign * (half_ref[rows, k] - 0.5 * sums[3] / total)
        point[rows, (k + 1) % 3] = a * e1[:, 0] + b * e2[:, 0]
        point[rows, (k + 2) % 3] = a * e1[:, 1] + b * e2[:, 1]
    return point


def _grid_rectangle(t, rot, half_i, half_r, axis, sign):
    """The grid's axes ``e1``, ``e2`` (m, 2) and extents ``low``, ``high`` (m, 2) of m pairs in
    their reference frames (:func:`impactnet.training.bench.accuracy.cop_frame.grid_frame`); the
    face's corners inside the footprint are found with the depth itself."""
    rows = np.arange(len(t))
    points, valid = support_points(t, rot, half_i, half_r, axis, sign)
    half_u, half_w = half_r[rows, (axis + 1) % 3], half_r[rows, (axis + 2) % 3]
    plain = np.broadcast_to([[1.0, 0.0]], (len(t), 2))  # the face's own (u, w) axes
    corner_coef = constraints(t, rot, half_i, half_r, axis, sign, plain, plain[:, ::-1])
    corner_u, corner_w = half_u[:, None] * _CORNER_U, half_w[:, None] * _CORNER_W
    corner_inside = depth_at(corner_coef[..., None], corner_u, corner_w) > 0.0
    return grid_frame(points, valid, *clipped_points(points, valid, half_u, half_w,
                                                     corner_inside))


def centre_of_pressure(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b,
                       normal, grid: int = DEFAULT_GRID,
                       refine: int = DEFAULT_REFINE,
                       estimate_error: bool = True) -> CentreOfPressure:
    """Grid centre of pressure on the face best aligned with ``normal`` (module docstring).

    Parameters
    ----------
    size_a, size_b : array_like, shape (n, 3)
        Full edge lengths (metres).
    position_a, position_b : array_like, shape (n, 3)
        Box centres, world frame (metres).
    quaternion_a, quaternion_b : array_like, shape (n, 4)
        Orientations (w, x, y, z).
    normal : array_like, shape (n, 3)
        Unit contact normals from A towards B (e.g. MuJoCo's); they pick the reference face.
    grid : int, optional
        Cells per side, G >= 2 (the error estimate uses G // 2).
    refine : int, optional
        Lattice points per cell on the footprint's edge (a Fibonacci number).
    estimate_error : bool, optional
        Also solve on the half grid for ``error`` (about 30 % more time); NaN otherwise.

    Returns
    -------
    CentreOfPressure
    """
    frame = reference_frame(size_a, position_a, quaternion_a, size_b, position_b,
                            quaternion_b, normal)
    centre_r, rot_r, t, rot, half_i, half_r, axis, sign, ref_is_b = frame
    n = len(t)
    local, coarse = np.empty((n, 3)), np.full((n, 3), np.nan)
    volume, footprint = np.zeros(n), np.zeros(n)
    block = max(1, BLOCK_POINTS // (4 * grid * grid))  # edge cells add ~3 G^2 points
    for start in range(0, n, block):
        s = slice(start, min(n, start + block))
        e1, e2, low, high = _grid_rectangle(t[s], rot[s], half_i[s], half_r[s], axis[s],
                                            sign[s])
        coef = constraints(t[s], rot[s], half_i[s], half_r[s], axis[s], sign[s], e1, e2)
        sums = _grid_sums(coef, low, high, grid, refine)
        local[s] = _local_point(sums, e1, e2, axis[s], sign[s], half_r[s])
        if estimate_error:
            half_grid = _grid_sums(coef, low, high, max(1, grid // 2), refine)
            coarse[s] = _local_point(half_grid, e1, e2, axis[s], sign[s], half_r[s])
        sides = np.maximum(high - low, 0.0)
        volume[s] = sums[0] * sides[:, 0] * sides[:, 1] / grid ** 2
        footprint[s] = np.where(sums[0] > 0.0, sides.max(axis=1), 0.0)
    point = centre_r + np.einsum("nij,nj->ni", rot_r, local)
    error = np.linalg.norm(local - coarse, axis=1)
    return CentreOfPressure(point, error, ref_is_b, axis, sign, volume, footprint)
