"""The separating-axis test's face axes (stage 2 of
:func:`~impactnet.models.compound.convex_sat.sat_rows`): each face's separation from the other
hull's support, found by steepest descent over the other hull's vertex graph with near-ties flooded
(:mod:`~impactnet.models.compound.convex_sat`'s docstring gives the argument), the tie rule's
face and the rotation of a hull's rows into the other's frame (stage 1)."""
from __future__ import annotations

import numpy as np

from impactnet.models.box.tolerances import TIE_TOL_REL
from impactnet.models.compiled import jit

#: A support search's local minimum is the minimum unless a neighbour lies within this (x the
#: searched points' reach plus |t|, metres) of it: 4500 ulps of the magnitudes the values are
#: computed from, above their rounding and the hulls' own flatness
#: (:data:`~impactnet.models.compound.hull_stack.CLIMB_FLAT_TOL_REL`) with a wide margin.
FLOOD_TOL_REL = 1e-12


@jit
def maximum(a, b):
    """``np.maximum`` of two floats (the first on ties, so -0.0 stays -0.0 as there)."""
    return a if a >= b else b


@jit
def minimum(a, b):
    """``np.minimum`` of two floats."""
    return a if a <= b else b


@jit
def turn(src, s0, n, rot, k, t, shifted, sign, dst):
    """``dst[i] = t[k] + R src[s0 + i]`` where ``shifted``, else ``sign R src[s0 + i]``
    (i < n, ``R = rot[k]``), each component ``(r0 x0 + r1 x1) + r2 x2`` as the NumPy solver
    rotated."""
    r00, r01, r02 = rot[k, 0, 0], rot[k, 0, 1], rot[k, 0, 2]
    r10, r11, r12 = rot[k, 1, 0], rot[k, 1, 1], rot[k, 1, 2]
    r20, r21, r22 = rot[k, 2, 0], rot[k, 2, 1], rot[k, 2, 2]
    for i in range(n):
        x0, x1, x2 = src[s0 + i, 0], src[s0 + i, 1], src[s0 + i, 2]
        v0 = r00 * x0 + r01 * x1 + r02 * x2
        v1 = r10 * x0 + r11 * x1 + r12 * x2
        v2 = r20 * x0 + r21 * x1 + r22 * x2
        if shifted:
            dst[i, 0], dst[i, 1], dst[i, 2] = t[k, 0] + v0, t[k, 1] + v1, t[k, 2] + v2
        else:
            dst[i, 0], dst[i, 1], dst[i, 2] = sign * v0, sign * v1, sign * v2


@jit
def flood(points, base, starts, neighbours, vbase, start, value, d0, d1, d2, slack, mark,
          queue, stamp):
    """The smallest ``p . d`` over the vertices connected to ``start`` through vertices within
    ``slack`` of its value ``value`` (module docstring): (value, vertex). ``points[base + v]``
    is vertex v, its neighbours ``neighbours[starts[vbase + v]:starts[vbase + v + 1]]``;
    ``mark``, ``queue`` and the last mark ``stamp[0]`` are scratch."""
    stamp[0] += 1
    now = stamp[0]
    limit = value + slack
    best, arg = value, start
    mark[start] = now
    queue[0] = start
    head, tail = 0, 1
    while head < tail:
        u = queue[head]
        head += 1
        for k in range(starts[vbase + u], starts[vbase + u + 1]):
            x = neighbours[k]
            if mark[x] == now:
                continue
            mark[x] = now
            w = points[base + x, 0] * d0 + points[base + x, 1] * d1 + points[base + x, 2] * d2
            if w <= limit:
                queue[tail] = x
                tail += 1
                if w < best:
                    best, arg = w, x
    return best, arg


@jit
def separations(points, base, count, climb, starts, neighbours, vbase, order, parent, first,
                nf, normals, nbase, offsets, obase, support, sep, gap, slack, mark, queue,
                stamp, stop):
    """``sep[f] = min_v (p_v . n_f) - h_f``, ``support[f]`` its vertex and ``gap[f]`` the
    second smallest value less the smallest (0 on ties) for the nf faces of one hull against
    the vertices ``points[base:base + count]`` of the other (module docstring): faces in the
    order of their tree (``order[first + k]``, ``parent[first + k]``), normals
    ``normals[nbase + f]``, offsets ``offsets[obase + f]``. A scan of every vertex for the
    first face and where the other hull may not be climbed on, else a climb from the parent's
    support (the second smallest vertex neighbours the smallest); ties of a local minimum
    flooded (:func:`flood`). Returns True as soon as a face separates by more than ``stop``
    (metres; ``inf``: every face), the later faces left unsearched."""
    for k in range(nf):
        f, up = order[first + k], parent[first + k]
        d0, d1, d2 = normals[nbase + f, 0], normals[nbase + f, 1], normals[nbase + f, 2]
        if not climb or up < 0:
            value, second, v = np.inf, np.inf, 0
            for q in range(count):
                w = (points[base + q, 0] * d0 + points[base + q, 1] * d1
                     + points[base + q, 2] * d2)
                if w < value:
                    value, second, v = w, value, q
                elif w < second:
                    second = w
            gap[f] = second - value
        else:
            v = support[up]
            value = points[base + v, 0] * d0 + points[base + v, 1] * d1 + points[base + v, 2] * d2
            while True:
                lowest, step = np.inf, -1
                for s in range(starts[vbase + v], starts[vbase + v + 1]):
                    u = neighbours[s]
                    w = (points[base + u, 0] * d0 + points[base + u, 1] * d1
                         + points[base + u, 2] * d2)
                    if w < lowest:
                        lowest, step = w, u
                if lowest < value:
                    v, value = step, lowest
                    continue
                gap[f] = lowest - value
                if lowest <= value + slack:
                    value, v = flood(points, base, starts, neighbours, vbase, v, value, d0, d1,
                                     d2, slack, mark, queue, stamp)
                    gap[f] = 0.0
                break
        support[f] = v
        sep[f] = value - offsets[obase + f]
        if sep[f] > stop:
            return True
    return False


@jit
def face_choice(sep_a, nfa, sep_b, nfb, scale):
    """(best overlap, largest separation, tie-rule face, most separating face) over A's faces
    then B's (indices into that concatenation)."""
    top, top_face = -np.inf, 0
    for f in range(nfa + nfb):
        sep = sep_a[f] if f < nfa else sep_b[f - nfa]
        if sep > top:
            top, top_face = sep, f
    best = -top
    bar = best + TIE_TOL_REL * scale
    for f in range(nfa + nfb):
        sep = sep_a[f] if f < nfa else sep_b[f - nfa]
        if -sep <= bar:
            return best, top, f, top_face
    return best, top, 0, top_face


@jit
def face_normal(normals, fa0, normals_b, nfa, face):
    """The unit normal of face ``face`` of the concatenation (A's from ``fa0``, then B's in A's
    frame), from A towards B."""
    if face < nfa:
        return normals[fa0 + face, 0], normals[fa0 + face, 1], normals[fa0 + face, 2]
    g = face - nfa
    return -normals_b[g, 0], -normals_b[g, 1], -normals_b[g, 2]
