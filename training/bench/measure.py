"""The measurement: what is timed, how much, and the run over every method and pose set.

Per method and pose set (:func:`measure_method`):

* N = 1: ``method.one`` on one pair per call (1-D inputs), over distinct poses spread over the
  set; the first calls are warm-up; the median is reported (µs per call).
* Throughput: ``method.batch`` over N poses, one warm-up call (whose answers are scored), then
  the median of ``repeats`` timed calls. Vectorised methods take the whole set (N = 1e5 in the
  full plan); python-fcl loops take an evenly spread subsample whose size is reported as the
  N measured. Nothing is extrapolated.
* Errors against the exact solver's answers for the same poses
(:mod:`impactnet.training.bench.accuracy.errors`).
* Errors against independent references, MuJoCo's box-box and the grid centre of pressure
  (:mod:`impactnet.training.bench.accuracy.vs_mujoco`), on at most ``mujoco_poses`` of the scored
  poses.

Ratios to the exact solver use the exact solver's figures from the same run and pose set:
``time / exact time`` at N = 1, and per pair at the throughput N (exact at its own N).
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from impactnet.training.bench.accuracy import errors as er
from impactnet.training.bench.methods import LEARNED, Answer, Method
from impactnet.training.bench.paper import polygon as pg
from impactnet.training.bench.speed.section import QUICK_SPEED, SpeedPlan
from impactnet.training.bench.timing import median_per_call, median_repeated


@dataclass(frozen=True)
class BenchConfig:
    """How much to measure; :data:`QUICK` is the smoke-test plan, the defaults the full one."""

    scene: str = "quay_crane"  # scene name or TOML path (its pairs, depth range)
    seed: int = 0  # pose seed
    scene_poses: int = 100_000  # scene set size = N of the vectorised throughput
    figure2_tilts: int = 50  # Figure 2: tilts from 10 deg to 1e-6 rad
    figure2_per_tilt: int = 2_000  # Figure 2: placements per tilt
    single_calls: int = 2_000  # N = 1: timed calls per vectorised method
    loop_single_calls: int = 1_000  # N = 1: timed calls per FCL / polygon method
    single_warmup: int = 50  # N = 1: untimed calls first
    batch_repeats: int = 7  # timed batched calls (vectorised)
    loop_repeats: int = 3  # timed loops (FCL, polygon)
    fcl_poses: int = 100_000  # FCL Box-Box loop size (a subsample when below the set size)
    polygon_poses: int = 10_000  # polygon loop size per grid, scene set
    polygon_figure2_poses: int = 2_000  # polygon loop size per grid, Figure 2 set
    grid_sizes: tuple[int, ...] = pg.GRID_SIZES  # the paper's n
    learned: tuple[str, ...] = LEARNED  # load_predictor names
    bundle: str | None = None  # learned bundle folder; None = the shipped default
    http: bool = False  # also measure through the HTTP service
    http_requests: int = 2_000  # /v2/contact requests per mode (after warm-up)
    http_batch_repeats: int = 5  # timed /v2/contact/batch calls per mode
    mujoco_poses: int = 5_000  # scored poses compared with MuJoCo per method (0: no column)
    # the speed section against MuJoCo from Python and the stage profile; None: left out
    speed: SpeedPlan | None = SpeedPlan()


#: The smoke-test plan (`impactnet bench --quick`): well under a minute on two cores.
QUICK = BenchConfig(scene_poses=10_000, figure2_tilts=20, figure2_per_tilt=100,
                    single_calls=200, loop_single_calls=40, single_warmup=20,
                    batch_repeats=3, loop_repeats=1, fcl_poses=2_000, polygon_poses=100,
                    polygon_figure2_poses=40, http_requests=200, http_batch_repeats=2,
                    mujoco_poses=500, speed=QUICK_SPEED)


@dataclass
class Row:
    """One method on one pose set: its times, errors and ratios to the exact solver."""

    method: str  # Method.name
    family: str  # Method.family
    pose_set: str  # PoseSet.name
    status: str  # "ok" or "not available: <reason>"
    us_n1: float | None = None  # median µs per call, one pair per call
    n1_calls: int = 0  # timed calls behind it
    batch_n: int | None = None  # pairs per timed batch call / loop (the N measured)
    set_size: int = 0  # poses in the set (batch_n < set_size: a subsample)
    us_per_pair: float | None = None  # median batch time / batch_n, µs
    pairs_per_s: float | None = None  # batch_n / median batch time
    repeats: int = 0  # timed batches behind the median
    errors: dict | None = None  # ErrorSummary.to_dict()
    n1_vs_exact: float | None = None  # us_n1 / exact's us_n1
    per_pair_vs_exact: float | None = None  # us_per_pair / exact's us_per_pair
    info: dict = field(default_factory=dict)  # method info and diagnostics
    # impactnet.training.bench.accuracy.vs_mujoco.column_summary(); None: not measured
    vs_mujoco: dict | None = None

    def to_dict(self) -> dict:
        return asdict(self)


def _loop_size(method: Method, poses, config: BenchConfig) -> int:
    if method.family == "fcl":
        return config.fcl_poses
    if poses.name == "figure2":
        return config.polygon_figure2_poses
    return config.polygon_poses


def _variant_errors(answer: Answer, reference: Answer, scale) -> dict:
    """Error summaries of each polygon reduction
    (:data:`impactnet.training.bench.paper.polygon.VARIANTS`)."""
    out = {}
    for name in pg.VARIANTS:
        point, normal = answer.point.copy(), answer.normal.copy()
        for i, variant in enumerate(answer.extra.get("variants", [])):
            if variant is not None:
                point[i], normal[i] = variant[name]
        scored = Answer(answer.colliding, point, normal)
        out[name] = er.method_summary(er.row_errors(scored, reference, scale)).to_dict()
    return out


def _time_n1(method: Method, poses, calls: int, warmup: int) -> tuple[float, int]:
    rows = poses.subsample(calls + warmup)
    if len(rows) <= warmup:  # a tiny set: time every pose, warm up on the first ones
        warmup = max(0, len(rows) // 4)
    pairs = [poses.pair_args(int(i)) for i in rows]
    seconds, count = median_per_call(method.one, pairs, warmup)
    return 1e6 * seconds, count


def measure_method(method: Method, poses, reference: Answer, config: BenchConfig,
                   log=lambda message: None, tolerance=None, mujoco=None) -> Row:
    """Time and score one method on one pose set (see the module docstring).

    ``tolerance``: the scene's accuracy as (normal degrees, point per cent of the shortest
    edge), for the "within tolerance" share; None leaves it out. ``mujoco``: the pose set's
    :class:`impactnet.training.bench.accuracy.vs_mujoco.MujocoColumn`, or None for no "vs MuJoCo"
    column.
    """
    row = Row(method.name, method.family, poses.name, "ok", set_size=len(poses),
              info=dict(method.info))
    if method.unavailable:
        row.status = f"not available: {method.unavailable}"
        return row
    t0 = time.perf_counter()
    if method.prepare is not None:
        method.prepare(poses)
    rows = (np.arange(len(poses)) if method.vectorised
            else poses.subsample(_loop_size(method, poses, config)))
    args = poses.args(rows)
    calls = config.single_calls if method.vectorised else config.loop_single_calls
    repeats = config.batch_repeats if method.vectorised else config.loop_repeats
    try:
        row.us_n1, row.n1_calls = _time_n1(method, poses, calls, config.single_warmup)
        answer = method.batch(args, True)  # the warm-up call; its answers are scored
        seconds = median_repeated(lambda: method.batch(args, False), repeats, warmup=False)
    except Exception as exc:  # noqa: BLE001 - e.g. a learned bundle without this pair
        row.status = f"not available: {type(exc).__name__}: {exc}"
        return row
    row.batch_n, row.repeats = len(rows), repeats
    row.us_per_pair, row.pairs_per_s = 1e6 * seconds / len(rows), len(rows) / seconds
    scale, expected = poses.scale[rows], reference.take(rows)
    per_pose = er.row_errors(answer, expected, scale)
    row.errors = er.method_summary(per_pose, tolerance=tolerance).to_dict()
    if poses.tilt is not None:
        row.info["by_tilt"] = er.by_group(per_pose, poses.tilt[rows])
    _diagnostics(row, method, answer, expected, per_pose, poses, rows)
    if mujoco is not None:  # untimed: MuJoCo and the grid reference, cached per set of rows
        row.vs_mujoco = mujoco.score(answer, rows)
    log(f"  {method.name:<16} {poses.name:<8} N=1 {row.us_n1:9.1f} us | N={row.batch_n:>7,} "
        f"{row.pairs_per_s:>11,.0f} pairs/s | {time.perf_counter() - t0:5.1f} s")
    return row


def _diagnostics(row: Row, method: Method, answer: Answer, expected: Answer, per_pose,
                 poses, rows) -> None:
    """Who answered (learned); contact counts, the paper's bound and other rules (polygon)."""
    if "answered_by" in answer.extra:
        row.info["answered_by"] = answer.extra["answered_by"]
    if method.family != "polygon":
        return
    counts = [c for c in answer.extra.get("contacts", []) if c]
    row.info["contacts_per_pair_median"] = float(np.median(counts)) if counts else 0.0
    row.info["contacts_per_pair_max"] = int(max(counts)) if counts else 0
    scale = poses.scale[rows]
    bound = 100.0 * pg.cell_diagonal(poses.size_a[rows], poses.size_b[rows],
                                     method.info["grid"]) / scale
    compared = np.isfinite(per_pose.point_pct)
    within = per_pose.point_pct[compared] <= bound[compared]
    row.info["within_cell_diagonal"] = float(within.mean()) if within.size else None
    row.info["rule_variants"] = _variant_errors(answer, expected, scale)


def add_ratios(rows: list[Row]) -> None:
    """Fill the ratios to the exact solver's row of the same pose set."""
    exact = {r.pose_set: r for r in rows if r.family == "exact" and r.status == "ok"}
    for r in rows:
        ref = exact.get(r.pose_set)
        if ref is None or r.status != "ok":
            continue
        if r.us_n1 is not None and ref.us_n1:
            r.n1_vs_exact = r.us_n1 / ref.us_n1
        if r.us_per_pair is not None and ref.us_per_pair:
            r.per_pair_vs_exact = r.us_per_pair / ref.us_per_pair


def with_overrides(config: BenchConfig, **overrides) -> BenchConfig:
    """``config`` with the non-None ``overrides`` applied."""
    return replace(config, **{k: v for k, v in overrides.items() if v is not None})
