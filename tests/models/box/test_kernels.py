"""The compiled box solver (models/box/kernels.py): the same answers from every entry and every
thread, the preallocated entry, the input errors as they have always been raised, a warm-up
that leaves nothing to compile, and the work limit between chunks."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from impactnet.models import compiled
from impactnet.models.box import (
    decision,
    kernel_face,
    kernel_frame,
    kernel_inputs,
    kernel_pressure,
    kernel_sat,
    kernel_views,
    kernels,
)
from impactnet.models.box.exact import (
    InvalidBoxError,
    box_box,
    box_box_into,
    empty_contacts,
    prepare_inputs,
)
from impactnet.models.geometry.rotations import InvalidRotationError, quaternion_to_matrix
from impactnet.models.work import WorkLimit, WorkStopped, limited
from tests.models.box.test_exact_one import assert_rows_equal, family_poses
from tests.models.helpers import KEYS, in_threads

REPO = Path(__file__).resolve().parents[3]
OK = {"size_a": [1.0, 2.0, 3.0], "position_a": [0.0, 0.0, 0.0],
      "quaternion_a": [1.0, 0.0, 0.0, 0.0], "size_b": [1.0, 1.0, 1.0],
      "position_b": [0.5, 0.5, 1.9], "quaternion_b": [1.0, 0.0, 0.0, 0.0]}


def _poses(per_case=8, seed=2):
    p = family_poses(per_case=per_case, seed=seed)
    return [p[k] for k in KEYS]


def test_eight_threads_solving_batches_at_once_get_the_serial_answers():
    """Parallel batches (launched one at a time) and serial ones, from 8 threads at once, give
    the answers of the serial kernel alone."""
    args = _poses(per_case=24)
    n = len(args[0])
    serial = [box_box(*(a[s:s + 50] for a in args)) for s in range(0, n, 50)]
    assert n >= 2 * compiled.PARALLEL_MIN_ROWS

    def run(k: int) -> tuple:
        rows = slice(k * 7, n) if k % 2 else slice(k * 7, k * 7 + 30)  # parallel, serial
        return rows, [box_box(*(a[rows] for a in args)) for _ in range(3)]

    results = in_threads(run)
    for rows, answers in results:
        for answer in answers:
            for j, i in enumerate(range(n)[rows]):
                assert_rows_equal(answer, j, serial[i // 50].row(i % 50))


@pytest.mark.parametrize("n", [1, 5, compiled.PARALLEL_MIN_ROWS + 3])
def test_the_preallocated_entry_equals_box_box(n):
    args = [a[:n] for a in _poses(per_case=12)]
    if n == 1:
        args = [a[0] for a in args]  # six vectors: the one-pair entry
    expected = box_box(*args)
    out = empty_contacts(n)
    for _ in range(2):  # the same arrays again, as a simulator's next step
        assert box_box_into(out, *args) is out
        for name, value in expected.arrays().items():
            np.testing.assert_array_equal(getattr(out, name), value, err_msg=name)


def test_the_preallocated_entry_refuses_arrays_that_do_not_fit_and_writes_nothing_on_errors():
    out = empty_contacts(1)
    box_box_into(out, *OK.values())
    before = {name: value.copy() for name, value in out.arrays().items()}
    with pytest.raises(ValueError, match="out.colliding"):
        box_box_into(empty_contacts(2), *OK.values())
    for field, value in (("normal", np.zeros((1, 4))), ("point", np.zeros((1, 3), np.float32))):
        wrong = empty_contacts(1)
        setattr(wrong, field, value)
        for given in (list(OK.values()), [np.array(v) for v in OK.values()]):
            with pytest.raises(ValueError, match=f"out.{field}"):
                box_box_into(wrong, *given)
    with pytest.raises(InvalidBoxError):
        box_box_into(out, *([0.0, 1.0, 1.0], *list(OK.values())[1:]))
    for name, value in out.arrays().items():
        np.testing.assert_array_equal(value, before[name], err_msg=name)


def _batch(**changes):
    """Five copies of the valid pair, with ``{field: (rows or None, value)}`` changes (None:
    the whole input replaced)."""
    args = {k: np.repeat(np.array(v)[None], 5, axis=0) for k, v in OK.items()}
    for name, (rows, value) in changes.items():
        if rows is None:
            args[name] = np.asarray(value, float)
        else:
            args[name][rows] = value
    return [args[k] for k in KEYS]


def _pair(**changes):
    return [changes.get(k, v) for k, v in OK.items()]


NAN = float("nan")
#: Inputs, and the error they have always raised: class, field, rows and message (checked
#: against the NumPy solver before the kernels replaced it).
ERRORS = [
    (_pair(size_a=[NAN, 1, 1]), InvalidBoxError, "size_a", [0], "size_a: not finite (rows [0])"),
    (_pair(quaternion_a=[1.0, 0, 0]), InvalidBoxError, "quaternion_a", [],
     "quaternion_a: expected shape (4,) or (n, 4), got (3,) (rows [])"),
    (_pair(size_a=[NAN, 1, 1], position_a=[1.0, 2.0]), InvalidBoxError, "size_a", [0],
     "size_a: not finite (rows [0])"),
    (_pair(size_b=[1, -1, 1]), InvalidBoxError, "size_b", [0],
     "size_b: sizes must be > 0 (rows [0])"),
    (_pair(size_a=[1e-7, 1, 1]), InvalidBoxError, "size_a", [0],
     "size_a: sizes must be in [1e-06, 1e+06] m (rows [0])"),
    (_pair(position_a=[2e9, 0, 0]), InvalidBoxError, "position_a", [0],
     "position_a: |coordinates| must be <= 1e+09 m (rows [0])"),
    (_pair(quaternion_b=[1e-7, 0, 0, 0]), InvalidRotationError, "quaternion", [0],
     "invalid quaternion: norm below 1e-06 (no rotation) at rows [0]"),
    (_batch(position_a=([1, 3], [NAN, 0, 0])), InvalidBoxError, "position_a", [1, 3],
     "position_a: not finite (rows [1, 3])"),
    (_batch(size_a=(None, [0.0, 1, 1])), InvalidBoxError, "size_a", [0, 1, 2, 3, 4],
     "size_a: sizes must be > 0 (rows [0, 1, 2, 3, 4])"),
    (_batch(size_a=(None, [NAN, 1, 1])), InvalidBoxError, "size_a", [0],
     "size_a: not finite (rows [0])"),
    (_batch(quaternion_a=(None, np.zeros(4))), InvalidRotationError, "quaternion",
     [0, 1, 2, 3, 4], "invalid quaternion: norm below 1e-06 (no rotation) at rows "
                      "[0, 1, 2, 3, 4]"),
    (_batch(position_b=(None, np.zeros((3, 3)))), InvalidBoxError, "pairs", [],
     "pairs: inputs do not broadcast: row counts [3, 5] (rows [])"),
    (_batch(position_b=(None, np.zeros((3, 3))), size_a=([1], [NAN, 1, 1])), InvalidBoxError,
     "size_a", [1], "size_a: not finite (rows [1])"),
    (_batch(size_b=([0], [0, 1, 1]), size_a=([3], [1e-9, 1, 1])), InvalidBoxError, "size_a",
     [3], "size_a: sizes must be in [1e-06, 1e+06] m (rows [3])"),
    (_batch(quaternion_a=([0], [0, 0, 0, 0]), position_b=([4], [0, 0, 3e9])), InvalidBoxError,
     "position_b", [4], "position_b: |coordinates| must be <= 1e+09 m (rows [4])"),
    (_batch(size_a=([0], [0, 1, 1]), quaternion_b=([1], [NAN, 0, 0, 0])), InvalidBoxError,
     "quaternion_b", [1], "quaternion_b: not finite (rows [1])"),
]


@pytest.mark.parametrize("args, kind, field, rows, message", ERRORS)
def test_input_errors_name_the_same_fields_and_rows(args, kind, field, rows, message):
    """Every entry raises the first fault in the same order, with every offending row: lists,
    vectors (the one-pair kernel) and arrays alike."""
    for given in (args, [np.asarray(a, float) for a in args]):
        with pytest.raises(kind) as raised:
            box_box(*given)
        assert (raised.value.field, list(raised.value.rows), str(raised.value)) == (
            field, rows, message)
        with pytest.raises(kind):
            box_box_into(empty_contacts(5), *given)


def test_orientations_given_as_matrices_answer_as_the_quaternions():
    """The row function given rotation matrices (the entry other kernels call) answers as
    ``box_box`` when the matrices are the quaternions' (the same formula)."""
    args = _poses(per_case=4)
    unit = [prepare_inputs(*args)[k] for k in (2, 5)]
    found = decision.box_box_matrices(args[0], args[1], quaternion_to_matrix(unit[0]),
                                      args[3], args[4], quaternion_to_matrix(unit[1]))
    expected = box_box(*args)
    for name, value in expected.arrays().items():
        np.testing.assert_array_equal(getattr(found, name), value, err_msg=name)


def _dispatchers() -> dict:
    found = {}
    for module in (kernel_inputs, kernel_frame, kernel_sat, kernel_face, kernel_pressure,
                   kernels, kernel_views):
        for name, value in vars(module).items():
            if isinstance(value, compiled.numba.core.registry.CPUDispatcher):
                found[f"{module.__name__}.{name}"] = value
    return found


def nothing_compiles_after_the_warm_up() -> dict:
    """In this process: the box warm-up, then calls of every entry with inputs of every kind;
    returns the dispatchers whose signatures grew after the warm-up (name: (before, after))."""
    from impactnet.models.box import warm_up

    assert warm_up.warm_up in compiled._WARM_UPS  # registered: compiled.warm_up() runs it
    warm_up.warm_up()
    dispatchers = _dispatchers()
    assert len(dispatchers) > 40 and "impactnet.models.box.kernels.solve_pair" in dispatchers
    before = {name: len(d.signatures) for name, d in dispatchers.items()}
    args = _poses(per_case=12)
    vectors = [a[0] for a in args]
    box_box(*vectors)
    box_box(*(v.tolist() for v in vectors))
    box_box(*(v.astype(np.float32) for v in vectors))  # refused by the closed kernel: shaped
    box_box(*(np.asfortranarray(a[:5]) for a in args))
    box_box(*(np.broadcast_to(v, (3, len(v))) for v in vectors))  # read-only views
    box_box(*args)
    box_box_into(empty_contacts(1), *vectors)
    box_box_into(empty_contacts(len(args[0])), *args)
    for bad in ERRORS:
        with pytest.raises(ValueError):
            box_box(*bad[0])
    decision.decisions(*args)
    decision.relative_pose(*args)
    decision.axis_table(*args)
    values = decision.single_pair(*vectors)
    decision.answer_one(decision.decide_one(values))
    with pytest.raises(TypeError):  # closed: another type is refused, not compiled for
        kernels.solve_one(*(v.astype(np.float32) for v in vectors), *kernels.output_arrays(1))
    return {name: (before[name], len(d.signatures)) for name, d in dispatchers.items()
            if len(d.signatures) != before[name]}


def test_after_the_warm_up_no_call_compiles():
    """The warm-up compiles (or loads) every kernel for every argument type the entries pass;
    then no entry compiles, whatever it is given, and the one-pair kernel is closed (checked in
    a fresh process: nothing compiled before the warm-up)."""
    code = ("import json; from tests.models.box.test_kernels import "
            "nothing_compiles_after_the_warm_up as check; print(json.dumps(check()))")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=1200, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {}


def test_a_cancelled_limit_stops_a_large_batch_between_chunks():
    args = _poses(per_case=12)
    limit = WorkLimit()
    with limited(limit), pytest.raises(WorkStopped):
        limit.cancel()
        box_box(*args)
