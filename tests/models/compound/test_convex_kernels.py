"""The compiled convex solver: the NumPy solver's recorded answers on seeded poses of twistlock
heads of 8 to 256 sides against a plate and against each other (random, resting and exactly
aligned), the search's shortcuts changing no bit, one row alone as in a batch, and several
threads at once answering as one after another."""
import dataclasses
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from impactnet.models import compiled
from impactnet.models.compiled import PARALLEL_MIN_ROWS
from impactnet.models.compound import convex_contact as cc
from impactnet.models.compound import convex_sat as cs
from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.hull import box_hull, hull_of
from impactnet.models.compound.hull_stack import stack_hulls
from tests.models.compound import convex_cases

RECORDED = np.load(convex_cases.DATA)
CASES = sorted({key.split("/")[0] for key in RECORDED.files})
POSE_KEYS = ("position_a", "rot_a", "position_b", "rot_b")


def _poses(name):
    return tuple(RECORDED[f"{name}/{key}"] for key in POSE_KEYS)


@pytest.mark.parametrize("name", CASES)
def test_the_kernels_give_the_numpy_solvers_answers(name):
    spec_a, spec_b = RECORDED[f"{name}/hulls"]
    got = convex_cases.solve(name, spec_a, spec_b, _poses(name), cc.convex_contacts,
                             cs.choose_axis)
    for key, value in got.items():
        np.testing.assert_array_equal(value, RECORDED[key], err_msg=key)


def _searched_plainly(table):
    """The same hulls with every support found by a scan of all vertices and every crossing
    edge pair evaluated (no climb, no bound): the search the kernels shortcut."""
    off = np.zeros(len(table.hulls), np.bool_)
    off.setflags(write=False)
    return dataclasses.replace(table, arrays=table.arrays._replace(convex=off, climb=off))


@pytest.mark.parametrize("sides", convex_cases.SIDES)
def test_climbs_and_bounds_change_no_bit(sides):
    """Supports by climbing and edge pairs dropped by their bounds give the answers of the
    plain search, on poses beyond the recorded ones (random, resting, aligned to 1e-12)."""
    head, plate = convex_cases.head(sides), convex_cases.hull_of("plate")
    families = [(head, convex_cases.head(sides), convex_cases.random_poses(head, head, 24, 11)),
                (head, convex_cases.head(sides),
                 convex_cases.resting_poses(head, head, 24, 12, 1e-2)),
                (head, convex_cases.head(sides), convex_cases.aligned_poses(head, head, 13)),
                (plate, head, convex_cases.random_poses(plate, head, 24, 14)),
                (plate, head, convex_cases.resting_poses(plate, head, 8, 15, 1e-6))]
    for a, b, (pa, ra, pb, rb) in families:
        ta, tb = stack_hulls((a,)), stack_hulls((b,))
        z = np.zeros(len(pa), np.int64)
        fast = cc.stacked_contacts(ta, z, tb, z, pa, ra, pb, rb).arrays()
        plain = cc.stacked_contacts(_searched_plainly(ta), z, _searched_plainly(tb), z, pa, ra,
                                    pb, rb).arrays()
        for field, column in fast.items():
            np.testing.assert_array_equal(column, plain[field], err_msg=field)


def _mixed():
    """A table of hulls of different sizes and rows of random pairs of them (touching and
    apart), more rows than a parallel launch needs."""
    container = cb.container("40ft", detail=2)
    ring = next(p for p in container if "/ring_" in p.name)
    hulls = (box_hull((0.2, 0.15, 0.1)), hull_of(ring), convex_cases.head(8),
             convex_cases.head(32), convex_cases.head(128))
    rng = np.random.default_rng(32)
    m = PARALLEL_MIN_ROWS + 44
    ia, ib = rng.integers(0, len(hulls), m), rng.integers(0, len(hulls), m)
    pa, ra, pb, rb = convex_cases.random_poses(hulls[0], hulls[0], m, 33, 0.08)
    centres = np.array([h.vertices.mean(axis=0) for h in hulls])
    pb = (pb + np.einsum("nij,nj->ni", ra, centres[ia] - centres[0])
          - np.einsum("nij,nj->ni", rb, centres[ib] - centres[0]))
    return stack_hulls(hulls), ia, ib, (pa, ra, pb, rb)


def test_one_row_is_its_row_of_a_batch():
    """The row kernel called on one row, with its own scratch, writes that row of the batch
    (the batch over the kernel threads), bit for bit; the test alone likewise."""
    table, ia, ib, (pa, ra, pb, rb) = _mixed()
    batch = cc.stacked_contacts(table, ia, table, ib, pa, ra, pb, rb)
    assert 0.2 < batch.colliding.mean() < 0.9
    t, rot = cc.relative_poses(pa, ra, pb, rb)
    t, rot = np.ascontiguousarray(t), np.ascontiguousarray(rot)
    axis = cs.choose_axis(table, table, t, rot, ia, ib)
    work = cc.make_work(*cc.work_sizes(table, table))
    for k in (0, 7, 100, len(ia) - 1):
        out = cc.contact_rows_for(len(ia))
        cc.contact_rows(table.arrays, ia, table.arrays, ib, t, rot, pa, ra, out, k, k + 1, work,
                         True)
        for field, column in out._asdict().items():
            np.testing.assert_array_equal(column[k], getattr(batch, field)[k], err_msg=field)
        one = cs.axis_rows(1)
        cs.sat_rows(table.arrays, ia, table.arrays, ib, t, rot, one, k, k, k + 1, work.sat, True)
        for field, column in one._asdict().items():
            np.testing.assert_array_equal(column[0], getattr(axis, field)[k], err_msg=field)


def test_threads_at_once_answer_as_one_after_another():
    """Several threads solving at once (small batches in their own threads, large ones over
    the kernel threads, one launch at a time) get the answers of the same calls in turn."""
    table, ia, ib, (pa, ra, pb, rb) = _mixed()
    pieces = [slice(0, 5), slice(5, 60), slice(0, len(ia)), slice(60, 61), slice(20, len(ia))]

    def solve(piece):
        return cc.stacked_contacts(table, ia[piece], table, ib[piece], pa[piece], ra[piece],
                                   pb[piece], rb[piece]).arrays()

    serial = [solve(piece) for piece in pieces]
    with ThreadPoolExecutor(max_workers=len(pieces)) as pool:
        for _ in range(3):
            for answer, expected in zip(pool.map(solve, pieces), serial):
                for field, column in answer.items():
                    np.testing.assert_array_equal(column, expected[field], err_msg=field)


def test_the_kernels_module_registers_the_convex_warm_up():
    from impactnet.models.compound import kernels  # noqa: F401 - imported for its warm-up

    assert cc.warm_up in compiled._WARM_UPS
    cc.warm_up()  # compiles or loads every convex kernel


def _with_scan(work, pairs: int):
    """``work`` whose rows scan every edge pair where they have at most ``pairs`` of them."""
    return work._replace(sat=work.sat._replace(scan=np.full(1, pairs, np.int64)))


def _small_families():
    """Rows of small hulls (a box, an aperture's ring piece, an 8-sided head), random, resting
    on each other and exactly aligned."""
    container = cb.container("40ft", detail=2)
    ring = hull_of(next(p for p in container if "/ring_" in p.name))
    box, head = box_hull((0.2, 0.15, 0.1)), convex_cases.head(8)
    pairs = [(box, ring), (ring, box), (ring, ring), (head, box), (ring, head)]
    for i, (a, b) in enumerate(pairs):
        yield a, b, convex_cases.random_poses(a, b, 40, 40 + i)
        yield a, b, convex_cases.resting_poses(a, b, 24, 50 + i, 1e-6)
        yield a, b, convex_cases.aligned_poses(a, b, 60 + i)


def test_scanning_every_edge_pair_gives_the_walks_answers():
    """Rows of small hulls test every edge pair (``SCAN_PAIRS``), larger ones walk the two
    Gauss-map trees: forced one way or the other on every row, every field of every row is
    the same bits (the walk drops only pairs that cannot change the answer), the test alone
    and the contacts, whole answers and separated rows stopped early."""
    table, ia, ib, (pa, ra, pb, rb) = _mixed()
    rows = [(table, ia, table, ib, (pa, ra, pb, rb))]
    for a, b, poses in _small_families():
        z = np.zeros(len(poses[0]), np.int64)
        rows.append((stack_hulls((a,)), z, stack_hulls((b,)), z, poses))
    seen = {"touching": 0, "apart": 0, "edge axes": 0}
    for ta, ia, tb, ib, (pa, ra, pb, rb) in rows:
        t, rot = cc.relative_poses(pa, ra, pb, rb)
        t, rot = np.ascontiguousarray(t), np.ascontiguousarray(rot)
        work, m = cc.make_work(*cc.work_sizes(ta, tb)), len(ia)
        answers = []
        for pairs in (0, 1 << 40):
            out = cc.contact_rows_for(m)
            cc.contact_rows(ta.arrays, ia, tb.arrays, ib, t, rot, np.ascontiguousarray(pa),
                             np.ascontiguousarray(ra), out, 0, m, _with_scan(work, pairs), True)
            whole, early = cs.axis_rows(m), cs.axis_rows(m)
            for axis, full in ((whole, True), (early, False)):
                cs.sat_rows(ta.arrays, ia, tb.arrays, ib, t, rot, axis, 0, 0, m,
                            _with_scan(work, pairs).sat, full)
            answers.append((out._asdict(), whole._asdict(), early.colliding))
        (walked, walked_axis, walked_early), (scanned, scanned_axis, scanned_early) = answers
        for ours, theirs in ((walked, scanned), (walked_axis, scanned_axis)):
            for field, column in ours.items():
                np.testing.assert_array_equal(column, theirs[field], err_msg=field)
        np.testing.assert_array_equal(walked_early, scanned_early)
        np.testing.assert_array_equal(walked_early, walked["colliding"])
        seen["touching"] += int(walked["colliding"].sum())
        seen["apart"] += int((~walked["colliding"]).sum())
        seen["edge axes"] += int((walked_axis["kind"] == cs.EDGE).sum())
    assert min(seen.values()) > 10, seen
