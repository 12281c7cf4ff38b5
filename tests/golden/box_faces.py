"""Margins of a box face contact's decisions: incident feature, clip, depth rule (not a test
module).

For the face-axis rows of :func:`tests.golden.box_decide.decide`, in the reference box's frame
with coordinates (axis, u, w) as in :mod:`impactnet.models.box.manifold`:

* feature: the incident face (the incident axis most anti-parallel to the normal: the gap
  between the largest and the next |component|), the touching count (each incident vertex's
  ``|depth + snap tol|``);
* clip: the 24 clip candidates of :mod:`impactnet.models.box.clip` (quad vertices in the
  rectangle, rectangle corners in the quad, edge crossings): a candidate's tests are ANDed, so
  its margin is its smallest test margin where all pass, the failing test's where one fails;
* region: the deepest point of the incident box inside the reference face's prism (the
  pressure region's deepest point, :mod:`impactnet.models.box.pressure`), against
  ``SAT depth - REGION_DEPTH_TOL_REL x scale`` (which depth is reported) and against ``-tau``
  (an empty region).

All lengths in metres; own code, no solver stage (see :mod:`tests.golden.box_axes`).
"""
from __future__ import annotations

import numpy as np

from tests.golden import rule

#: Quad vertices in cyclic order, as signs along the incident face's two in-plane axes.
QUAD_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
#: The 8 vertices of a box as signs (x, y, z) and its 12 edges as vertex pairs.
CORNERS = np.array([[x, y, z] for x in (1, -1) for y in (1, -1) for z in (1, -1)], float)
EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8)
         if np.abs(CORNERS[a] - CORNERS[b]).sum() == 2]


def and_margin(values: np.ndarray) -> np.ndarray:
    """Margin of ``all(values >= 0)`` over the last axis: the smallest |value| where all
    pass, the failing one's where exactly one fails, +inf where more fail."""
    fails = (values < 0.0).sum(axis=-1)
    size = np.abs(values)
    one = np.where(values < 0.0, size, np.inf).min(axis=-1)
    return np.where(fails == 0, size.min(axis=-1), np.where(fails == 1, one, np.inf))


def reference_view(pose, axis):
    """The m face rows seen from the reference box: half-extents along (axis, u, w) (m, 3),
    the incident centre (m, 3), the incident axes as columns (m, 3, 3), the incident
    half-extents (m, 3)."""
    m = len(axis)
    ref_b = axis >= 3
    cyc = (axis[:, None] % 3 + np.arange(3)) % 3
    half_ref = np.take_along_axis(np.where(ref_b[:, None], pose.hb, pose.ha), cyc, axis=1)
    tb = np.einsum("nij,ni->nj", pose.r, pose.t)
    centre = np.take_along_axis(np.where(ref_b[:, None], -tb, pose.t), cyc, axis=1)
    full = np.where(ref_b[:, None, None], pose.r.transpose(0, 2, 1), pose.r)
    rot = full[np.arange(m)[:, None], cyc]
    return half_ref, centre, rot, np.where(ref_b[:, None], pose.ha, pose.hb)


def incident_quad(centre, rot, half_inc):
    """The incident face's vertices (m, 4, 3), the side of the reference face (m,) and the
    incident-face choice's margin (m,): the gap between the two largest |normal components|."""
    m = len(centre)
    rows = np.arange(m)
    ref_sign = np.where(centre[:, 0] >= 0.0, 1.0, -1.0)
    n_inc = ref_sign[:, None] * rot[:, 0, :]
    size = np.sort(np.abs(n_inc), axis=1)
    k = np.argmax(np.abs(n_inc), axis=1)
    side = -np.where(n_inc[rows, k] >= 0.0, 1.0, -1.0)
    p, q = (k + 1) % 3, (k + 2) % 3
    face_centre = centre + (side * half_inc[rows, k])[:, None] * rot[rows, :, k]
    along_p = half_inc[rows, p][:, None] * rot[rows, :, p]
    along_q = half_inc[rows, q][:, None] * rot[rows, :, q]
    quad = (face_centre[:, None] + QUAD_SIGNS[None, :, 0, None] * along_p[:, None]
            + QUAD_SIGNS[None, :, 1, None] * along_q[:, None])
    return quad, ref_sign, size[:, 2] - size[:, 1]


def _corner_tests(qu, qw, depth, hu, hw, tol):
    """Test values (m, 4 corners, 4 tests) of the rectangle corners inside the quad."""
    cu, cw = qu.mean(axis=1), qw.mean(axis=1)
    a0, a1 = 0.5 * (qu[:, 0] - qu[:, 1]), 0.5 * (qw[:, 0] - qw[:, 1])
    b0, b1 = 0.5 * (qu[:, 1] - qu[:, 2]), 0.5 * (qw[:, 1] - qw[:, 2])
    det = a0 * b1 - a1 * b0
    len_a, len_b = np.hypot(a0, a1), np.hypot(b0, b1)
    d_c = depth.mean(axis=1)
    d_a, d_b = 0.5 * (depth[:, 0] - depth[:, 1]), 0.5 * (depth[:, 1] - depth[:, 2])
    corner_u, corner_w = QUAD_SIGNS[:, 0] * hu[:, None], QUAD_SIGNS[:, 1] * hw[:, None]
    ru, rw = corner_u - cu[:, None], corner_w - cw[:, None]
    alpha = (ru * b1[:, None] - rw * b0[:, None]) / det[:, None]
    beta = (a0[:, None] * rw - a1[:, None] * ru) / det[:, None]
    d = d_c[:, None] + alpha * d_a[:, None] + beta * d_b[:, None]
    gap = np.hypot(corner_u[:, :, None] - qu[:, None], corner_w[:, :, None] - qw[:, None])
    t = tol[:, None]
    return np.stack([t - (np.abs(alpha) - 1.0) * len_a[:, None],
                     t - (np.abs(beta) - 1.0) * len_b[:, None], d + t, gap.min(axis=2) - t],
                    axis=2)


def _crossing_tests(qu, qw, depth, hu, hw, tol):
    """Test values (m, 16 crossings, 4 tests) of quad edges crossing the rectangle's edges
    (NaN-free: an edge parallel to a line gives no crossing, +inf tests)."""
    quad, half = (qu, qw), (hu, hw)
    nxt = [1, 2, 3, 0]
    out = []
    for e in range(4):
        delta = (quad[0][:, nxt[e]] - quad[0][:, e], quad[1][:, nxt[e]] - quad[1][:, e])
        length = np.hypot(*delta)
        for coord in (0, 1):
            for sign in (1.0, -1.0):
                moves = delta[coord] != 0.0
                tau = (sign * half[coord] - quad[coord][:, e]) / np.where(moves, delta[coord], 1)
                other = quad[1 - coord][:, e] + tau * delta[1 - coord]
                d = depth[:, e] + tau * (depth[:, nxt[e]] - depth[:, e])
                tests = np.stack([tau * length - tol, (1.0 - tau) * length - tol,
                                  half[1 - coord] - tol - np.abs(other), d + tol], axis=1)
                out.append(np.where(moves[:, None], tests, np.inf))
    return np.stack(out, axis=1)


def clip_margin(quad, ref_sign, half_ref, scale):
    """Clip margin (m,) metres and vertex depths (m, 4) of the incident quads."""
    tol = rule.SNAP_TOL_REL * scale
    height, hu, hw = half_ref.T
    depth = height[:, None] - ref_sign[:, None] * quad[:, :, 0]
    qu, qw = quad[:, :, 1], quad[:, :, 2]
    vertex = np.stack([hu[:, None] + tol[:, None] - np.abs(qu),
                       hw[:, None] + tol[:, None] - np.abs(qw), depth + tol[:, None]], axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        tests = [vertex, _corner_tests(qu, qw, depth, hu, hw, tol),
                 _crossing_tests(qu, qw, depth, hu, hw, tol)]
    margin = np.concatenate([and_margin(np.nan_to_num(t, nan=np.inf)) for t in tests], axis=1)
    return margin.min(axis=1), depth


def _line_depths(centre, rot, half_inc, corner_uw, height, ref_sign):
    """Deepest depth (m,) of the incident box along the prism's vertical line at (u, w) =
    ``corner_uw`` (m, 2); -inf where the line misses the box."""
    g = rot[:, 0, :]  # d(incident coordinate k) / d(s), s along the reference axis
    f = np.einsum("nck,nc->nk", rot[:, 1:, :], corner_uw - centre[:, 1:]) - g * centre[:, 0:1]
    with np.errstate(divide="ignore", invalid="ignore"):
        lo = np.where(g != 0.0, np.minimum((-half_inc - f) / g, (half_inc - f) / g), -np.inf)
        hi = np.where(g != 0.0, np.maximum((-half_inc - f) / g, (half_inc - f) / g), np.inf)
    lo = np.where((g == 0.0) & (np.abs(f) > half_inc), np.inf, lo).max(axis=1)
    hi = np.where((g == 0.0) & (np.abs(f) > half_inc), -np.inf, hi).min(axis=1)
    deepest = np.maximum(height - ref_sign * lo, height - ref_sign * hi)
    return np.where(lo <= hi, deepest, -np.inf)


def region_depth(centre, rot, half_inc, half_ref, ref_sign) -> np.ndarray:
    """The deepest depth (m,) of the incident box inside the reference face's prism (box
    vertices, box edges through the prism's sides, the prism's corner lines through the box),
    -inf where the box misses the prism."""
    height, hu, hw = half_ref.T
    vertices = centre[:, None] + np.einsum("nck,nvk->nvc", rot, CORNERS[None] * half_inc[:, None])
    depth = height[:, None] - ref_sign[:, None] * vertices[:, :, 0]
    inside = (np.abs(vertices[:, :, 1]) <= hu[:, None]) & (np.abs(vertices[:, :, 2]) <= hw[:, None])
    best = np.where(inside, depth, -np.inf).max(axis=1)
    bounds = (hu, hw)
    with np.errstate(divide="ignore", invalid="ignore"):
        for a, b in EDGES:
            step = vertices[:, b] - vertices[:, a]
            for coord in (1, 2):
                for sign in (1.0, -1.0):
                    tau = (sign * bounds[coord - 1] - vertices[:, a, coord]) / step[:, coord]
                    point = vertices[:, a] + tau[:, None] * step
                    ok = ((tau >= 0.0) & (tau <= 1.0)
                          & (np.abs(point[:, 3 - coord]) <= bounds[2 - coord]))
                    d = height - ref_sign * point[:, 0]
                    best = np.maximum(best, np.where(ok, d, -np.inf))
    for su, sw in QUAD_SIGNS:
        corner = np.stack([su * hu, sw * hw], axis=1)
        best = np.maximum(best, _line_depths(centre, rot, half_inc, corner, height, ref_sign))
    return best


def face_margins(pose, axis, sat_depth) -> dict:
    """Margins (each (m,), metres or dimensionless) of m face-axis contacts: feature_unit,
    feature_depth, clip, region, empty (module docstring)."""
    half_ref, centre, rot, half_inc = reference_view(pose, axis)
    quad, ref_sign, face_gap = incident_quad(centre, rot, half_inc)
    clip, depth = clip_margin(quad, ref_sign, half_ref, pose.scale)
    touching = np.abs(depth + (rule.SNAP_TOL_REL * pose.scale)[:, None]).min(axis=1)
    deepest = region_depth(centre, rot, half_inc, half_ref, ref_sign)
    tau = rule.PRESSURE_FLOOR_REL * pose.scale
    region = np.abs(np.maximum(deepest, 0.0) - sat_depth
                    + rule.REGION_DEPTH_TOL_REL * pose.scale)
    region = np.where(deepest >= -tau, region, np.inf)
    rank = np.clip((depth >= -(rule.SNAP_TOL_REL * pose.scale)[:, None]).sum(axis=1), 1, 3)
    return {"feature_unit": face_gap, "feature_depth": touching, "clip": clip,
            "region": region, "empty": np.abs(deepest + tau), "rank": rank}
