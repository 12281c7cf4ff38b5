"""Where the profile's stages come from: the stages of today's solvers, each a zero-argument
callable on inputs prepared here (:mod:`impactnet.training.bench.speed.stages` times them).

Each solver has ONE source function, marked ``KERNEL SWITCH``: when the compiled kernels land
(the public entries ``box_box`` and ``compound_answer`` keep their signatures), that function
is the single place to change, returning the kernels' stage entries under the same names (a
fused kernel may return fewer stages: the profile's "rest" line takes what they do not cover).
A source that no longer finds today's stage functions makes the profile say so instead of
failing the benchmark.
"""
from __future__ import annotations

import numpy as np

from impactnet.training.bench.speed.stages import PART_OF


def box_stages(args: tuple) -> tuple[dict, object]:
    """KERNEL SWITCH (box solver). ``(stages, whole)`` of the box solver on the six (n, .)
    arguments ``args``; ``whole`` is ``box_box``. The vectorised NumPy solver (it has
    ``solve_local``) gives its stages (:func:`_numpy_box_stages`), the compiled one
    (``models/box/kernels.py``) those its entries allow (:func:`_kernel_box_stages`)."""
    from impactnet.models.box import exact

    if hasattr(exact, "solve_local"):
        return _numpy_box_stages(args), lambda: exact.box_box(*args)
    return _kernel_box_stages(args), lambda: exact.box_box(*args)


def _numpy_box_stages(args: tuple) -> dict:
    """The NumPy solver's stages: input checks; the local frame (A's frame, in blocks of the
    solver's ``CHUNK_ROWS``); the separating axes, manifold, centre of pressure and depth in
    A's frame (``solve_local``), with the separating axes alone as its part. The rest is the
    world frame and the answer's arrays (``to_world``)."""
    from impactnet.models.box import exact
    from impactnet.models.box import local_frame as lf

    inputs = exact.prepare_inputs(*args)
    n = len(inputs[0])
    spans = [(s, min(n, s + exact.CHUNK_ROWS)) for s in range(0, n, exact.CHUNK_ROWS)]
    poses = [lf.local_pose(lf.input_columns(inputs, s, e))[0] for s, e in spans]
    return {
        "input checks": lambda: exact.prepare_inputs(*args),
        "local frame": lambda: [lf.local_pose(lf.input_columns(inputs, s, e)) for s, e in spans],
        "axes, manifold, point, depth": lambda: [exact.solve_local(p) for p in poses],
        PART_OF + "separating axes, edge contacts": lambda: [exact.contact_axes(p)
                                                             for p in poses],
    }


def _kernel_box_stages(args: tuple) -> dict:
    """The compiled solver's stages: the inputs shaped into float64 rows; the output arrays;
    the kernels' checks and the fused row kernel over the kernel threads (frame, separating
    axes, manifold, centre of pressure, world frame: one kernel, one stage), with the checks
    alone as its part. The rest is the ``Contacts`` around the arrays."""
    from impactnet.models.box import exact, kernels
    from impactnet.models.box.kernel_inputs import first_fault

    rows, n = exact.checked_rows(*args)
    out = kernels.output_arrays(n)
    return {
        "input shaping": lambda: exact.checked_rows(*args),
        "output arrays": lambda: kernels.output_arrays(n),
        "checks and solve (fused kernel)": lambda: exact._solve(rows, n, out),
        PART_OF + "input checks": lambda: first_fault(*rows, n),
    }


def _body(parts, position, quaternion, n: int) -> tuple:
    """The oracle's body tuple: positions (n, 3), unit quaternions (n, 4), rotations
    (n, 3, 3) and the body table."""
    from impactnet.models.compound.body_table import body_table
    from impactnet.models.geometry.rotations import quaternion_to_matrix, validate_quaternion

    position = np.broadcast_to(np.atleast_2d(np.asarray(position, np.float64)), (n, 3))
    quaternion = validate_quaternion(np.atleast_2d(np.asarray(quaternion, np.float64)))
    quaternion = np.broadcast_to(quaternion, (n, 4))
    return position, quaternion, quaternion_to_matrix(quaternion), body_table(tuple(parts))


def compound_stages(parts_a, position_a, quaternion_a, parts_b, position_b,
                    quaternion_b) -> tuple[dict, object]:
    """KERNEL SWITCH (compound oracle). ``(stages, whole)`` of the compound oracle on n poses
    (at most one block of the oracle, ``ORACLE_CHUNK``): the broadphase as the oracle calls it
    (``broadphase.broadphase``; ``candidates.candidate_pairs``, the service's counted variant,
    finds the same pairs at a higher cost: validation, counts, work), the narrowphase of the
    box part pairs and of the pairs with a convex part (``oracle._narrowphase`` on each share
    of the candidates), the filter of covered surfaces (``oracle._hidden``) and the body-level
    summary (``summary.summarise``); ``whole`` is ``compound_answer``."""
    from impactnet.models.compound import oracle
    from impactnet.models.compound.answer import compound_answer
    from impactnet.models.compound.broadphase import broadphase
    from impactnet.models.compound.candidates import candidate_pairs
    from impactnet.models.compound.summary import summarise

    args = (parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b)
    n = max(len(np.atleast_2d(a)) for a in (position_a, quaternion_a, position_b, quaternion_b))
    if n > oracle.ORACLE_CHUNK:
        raise ValueError(f"profile at most {oracle.ORACLE_CHUNK} poses (one block), got {n}")
    body_a = _body(parts_a, position_a, quaternion_a, n)
    body_b = _body(parts_b, position_b, quaternion_b, n)
    found = candidate_pairs(*args)
    pose, i, j = found.pose, found.part_a, found.part_b
    box = body_a[3].is_box[i] & body_b[3].is_box[j]
    contacts = oracle._narrowphase(pose, i, j, body_a, body_b)
    rows = np.flatnonzero(contacts.colliding)
    parts = oracle.compound_contacts(*args)
    stages = {
        "broadphase": lambda: broadphase(body_a[3], body_b[3], body_b[0] - body_a[0], body_a[2],
                                         body_b[2]),
        "box parts": lambda: oracle._narrowphase(pose[box], i[box], j[box], body_a, body_b),
        "convex parts": lambda: oracle._narrowphase(pose[~box], i[~box], j[~box], body_a,
                                                    body_b),
        "covered-surface filter": lambda: oracle._hidden(contacts, rows, pose, i, j, body_a,
                                                         body_b),
        "summary": lambda: summarise(parts),
    }
    return stages, lambda: compound_answer(*args)
