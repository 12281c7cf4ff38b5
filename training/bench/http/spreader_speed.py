"""Issue #32's HTTP goals for a compound pair: a detail-2 spreader landing on a 40 ft container,
over loopback, against MuJoCo called from Python on the same poses, in one run.

    python -m impactnet.training.bench.http.spreader_speed [--poses 10000] [--requests 1000]

A server (``python -m impactnet.service``, scene ``quay_crane_detail``, mode ``exact``) on a
free loopback port, one keep-alive client (:class:`impactnet.service.client.ImpactClient`):

* ``GET /healthz`` p50 (the floor) and ``POST /v2/contact`` of the spreader pair, the poses in
  turn (goal: p50 at most 2x the floor's);
* ``POST /v2/contact/batch`` as npz of ``--poses`` poses, end to end: encode, send, solve,
  answer, decode (goal: at most 2x MuJoCo's Python loop over the same poses);
* MuJoCo 4 from Python, per pose: write both bodies' ``qpos``, ``mj_kinematics``,
  ``mj_collision`` on a model of the same geoms (one per part, meshes for convex parts,
  ``multiccd`` off), and copy the contacts' positions, frames and distances into arrays.

The poses: the spreader's landing pose (its twistlocks 5.5 mm into the castings) moved by up
to 5 mm and turned by up to 0.5 degrees about random axes, seeded.
"""
from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

from impactnet.training.bench.http.loopback import latency, percentiles
from impactnet.training.bench.http.predictors import running_server

#: The scene and the pair measured.
SCENE, A, B = "quay_crane_detail", "container40", "spreader"
#: The spreader's landing pose over the container (m), and the spread of the poses around it.
LANDED = np.array([0.0, 0.0045, 1.7005])
SHIFT_M, TURN_RAD = 0.005, np.radians(0.5)
#: The goals of issue #32 over HTTP (ratios).
CONTACT_OVER_FLOOR_MAX, BATCH_OVER_MUJOCO_MAX = 2.0, 2.0
IDENTITY = [1.0, 0.0, 0.0, 0.0]


def landing_poses(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(positions (n, 3) m, unit quaternions (n, 4)) of the spreader around its landing pose."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    half = 0.5 * rng.uniform(-TURN_RAD, TURN_RAD, n)
    quaternion = np.column_stack([np.cos(half), axis * np.sin(half)[:, None]])
    return LANDED + rng.uniform(-SHIFT_M, SHIFT_M, (n, 3)), quaternion


def mujoco_loop(position: np.ndarray, quaternion: np.ndarray) -> dict:
    """MuJoCo from Python over every pose (module docstring): total seconds, contacts."""
    import mujoco as mj

    from impactnet.models.dispatch.shapes import scene_shapes
    from impactnet.models.scenes import load_scene
    from impactnet.training.bench.compound.mujoco_model import mujoco_model

    shapes = scene_shapes(load_scene(SCENE))
    model, data = mujoco_model(shapes[A].parts, shapes[B].parts, multiccd=False)
    qpos = np.zeros((len(position), 14))
    qpos[:, 3] = 1.0
    qpos[:, 7:10], qpos[:, 10:] = position, quaternion
    contacts = 0
    start = time.perf_counter()
    for row in qpos:
        data.qpos[:] = row
        mj.mj_kinematics(model, data)
        mj.mj_collision(model, data)
        k = data.ncon
        copied = (data.contact.pos[:k].copy(), data.contact.frame[:k].copy(),
                  data.contact.dist[:k].copy())  # what a caller needs of the answer
        contacts += len(copied[2])
    return {"seconds": time.perf_counter() - start, "poses": len(qpos), "contacts": contacts}


def measure(poses: int, requests: int, log=print) -> dict:
    """Every figure of the module docstring, in one run."""
    position, quaternion = landing_poses(max(poses, requests))
    out = {"mujoco": mujoco_loop(position[:poses], quaternion[:poses])}
    with running_server(SCENE, None, log) as (client, info):
        out["server"] = info
        out["floor"] = latency(lambda: client.request("GET", "/healthz"), requests, 50)
        turn = itertools.count()

        def one():
            i = next(turn) % len(position)
            client.contact({"object": A, "position": [0, 0, 0], "quaternion": IDENTITY},
                           {"object": B, "position": position[i].tolist(),
                            "quaternion": quaternion[i].tolist()}, mode="exact")

        out["contact"] = latency(one, requests, 50)
        columns = {"a_object": np.array(A), "a_position": np.zeros(3),
                   "a_quaternion": np.array(IDENTITY), "b_object": np.array(B),
                   "b_position": position[:poses], "b_quaternion": quaternion[:poses]}
        times = []
        for _ in range(3):
            start = time.perf_counter()
            answer = client.batch(columns, mode="exact")
            times.append(time.perf_counter() - start)
        out["batch"] = {"poses": poses, **percentiles(times),
                        "seconds": float(np.median(times)),
                        "colliding": int(np.asarray(answer["colliding"]).sum())}
    out["contact_over_floor"] = out["contact"]["p50_ms"] / out["floor"]["p50_ms"]
    out["batch_over_mujoco"] = out["batch"]["seconds"] / out["mujoco"]["seconds"]
    return out


def report(out: dict) -> str:
    """The figures as a markdown table."""
    f, c, b, m = out["floor"], out["contact"], out["batch"], out["mujoco"]
    ratio_c, ratio_b = out["contact_over_floor"], out["batch_over_mujoco"]
    return "\n".join([
        f"Spreader on a 40 ft container (`{SCENE}`, detail 2), mode exact, one keep-alive "
        "client on loopback; MuJoCo 4 from Python on the same poses.", "",
        "| measurement | figure | ratio | goal | met |", "|---|---|---|---|---|",
        f"| GET /healthz p50 (floor) | {f['p50_ms']:.3f} ms | 1x | | |",
        f"| POST /v2/contact p50, the spreader pair | {c['p50_ms']:.3f} ms (p99 "
        f"{c['p99_ms']:.3f}) | {ratio_c:.1f}x the floor | <= {CONTACT_OVER_FLOOR_MAX:g}x | "
        f"{'yes' if ratio_c <= CONTACT_OVER_FLOOR_MAX else 'no'} |",
        f"| {b['poses']:,} poses as an npz batch, end to end (median of 3) | "
        f"{b['seconds']:.3f} s | {ratio_b:.1f}x MuJoCo's loop | <= {BATCH_OVER_MUJOCO_MAX:g}x | "
        f"{'yes' if ratio_b <= BATCH_OVER_MUJOCO_MAX else 'no'} |",
        f"| MuJoCo from Python, the same {m['poses']:,} poses | {m['seconds']:.3f} s "
        f"({1e6 * m['seconds'] / m['poses']:.1f} us a pose) | 1x | | |"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m impactnet.training.bench.http."
                                     "spreader_speed", description=__doc__.split("\n")[0])
    parser.add_argument("--poses", type=int, default=10_000, help="poses of the npz batch")
    parser.add_argument("--requests", type=int, default=1_000, help="timed single requests")
    args = parser.parse_args(argv)
    print(report(measure(args.poses, args.requests)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
