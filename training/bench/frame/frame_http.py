"""A frame over HTTP (POST /v2/frame, npz both ways) against MuJoCo called from Python, in one
run (issue #34, item 5).

A server (``python -m impactnet.service``,
:func:`impactnet.training.bench.http.predictors.running_server`) is started on 127.0.0.1 at a free
port, serving the bench scene (:func:`~impactnet.training.bench.frame.worlds.scene_toml`, written to
a temporary folder; no bundle: mode ``exact``) with the kernels' threads of this process. One
keep-alive client (:class:`impactnet.service.client.ImpactClient`, the simulator's) sends, per
variant:

* **everything sent**: every body's columns (``id``, ``object``, ``position``, ``quaternion``),
  every body free: against MuJoCo's frame with every body free;
* **world registered, spreader sent**: the yard and the guides registered once (POST
  /v2/worlds), then per frame the spreader's columns naming the world: against MuJoCo's frame
  with the world welded and the spreader free.

The timed call is the client's: the request's npz built, sent, answered, and the answer read
into arrays. Both sides are timed in alternating slices, their pairs compared first (the ids
the server answers against the in-process frame's). The profile (:func:`server_stages`) runs
the server's steps in this process on the same request (parse, decode, broadphase, solve, the
frame's answer, the npz answer) and the client's (the request's npz, the answer's reading);
what the HTTP call costs beyond them is the transport, the event loop and the lanes' thread
hops.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from impactnet.training.bench.frame import worlds
from impactnet.training.bench.frame.speed import FramePlan, time_pair

#: The request's query of a frame without options (npz frames give them in the query).
#: The registered world's name in the in-process profile (a valid name: ``w-`` and hex digits).
BENCH_WORLD = "w-00be7c4"
NO_OPTIONS = {"world": None, "margin": None, "pairs": None, "mode": None, "include": None,
              "euler_convention": None}


def _sent(columns: dict, moving: int):
    """The columns of the last ``moving`` bodies at given poses (a call's request)."""
    def at(position, quaternion):
        return {**columns, "position": position[-moving:], "quaternion": quaternion[-moving:]}

    return at


def server_stages(scene_path: str, columns: dict, world, http_call, args: tuple):
    """``(stages, whole)``: the server's steps and the client's on one request, in this
    process (module docstring); ``world``: the registered world's JSON body objects or None;
    ``whole``: the HTTP call."""
    from impactnet.models.dispatch import Dispatcher
    from impactnet.models.frame import frame_answer
    from impactnet.service import frame_steps as steps
    from impactnet.service.codecs.frame_answers import frame_npz
    from impactnet.service.codecs.npz_format import read_npz, write_npz
    from impactnet.service.limits.budget import Lease, MemoryBudget
    from impactnet.service.scene import load_scene_view
    from impactnet.service.settings import Settings
    from impactnet.service.solve import solve_now
    from impactnet.service.worlds import Worlds

    settings = Settings(scene=scene_path, bundle="none")
    scene, dispatcher = load_scene_view(scene_path), Dispatcher()
    budget = MemoryBudget(settings.memory_budget_bytes, 0.0, 1)
    held = None
    if world is not None:
        import orjson

        parsed = steps.parse(orjson.dumps({"bodies": world}), False, {"euler_convention": None},
                             settings, Lease(budget), True)
        registry = Worlds(1)
        registry.add(BENCH_WORLD, steps.decode(parsed, scene, settings, Lease(budget)))
        held = registry.get(BENCH_WORLD)
    body = write_npz(columns)
    query = {**NO_OPTIONS, "world": BENCH_WORLD if world is not None else None}
    parsed = steps.parse(body, True, query, settings, Lease(budget))
    bodies = steps.decode(parsed, scene, settings, Lease(budget), held, [])
    found = steps.broadphase(bodies, parsed.options, scene, settings)
    answers = solve_now(dispatcher, found.pairs, "exact", (), 0.0, settings)
    result = frame_answer(bodies, found, answers)
    answer = b"".join(frame_npz(result, (), "exact", "bench"))
    stages = {
        "client: the request's npz": lambda: write_npz(columns),
        "server: parse the npz": lambda: steps.parse(body, True, query, settings,
                                                     Lease(budget)),
        "server: decode the bodies (and join the world)":
            lambda: steps.decode(parsed, scene, settings, Lease(budget), held, []),
        "server: broadphase": lambda: steps.broadphase(bodies, parsed.options, scene, settings),
        "server: solve (plan, count, solve)":
            lambda: solve_now(dispatcher, found.pairs, "exact", (), 0.0, settings),
        "server: the frame's answer": lambda: frame_answer(bodies, found, answers),
        "server: encode the npz answer": lambda: b"".join(frame_npz(result, (), "exact",
                                                                    "bench")),
        "client: read the answer": lambda: read_npz(answer),
    }
    return stages, lambda: http_call(*args)


def _ids(answer: dict) -> set[tuple[str, str]]:
    return set(zip(np.asarray(answer["a"]).tolist(), np.asarray(answer["b"]).tolist()))


def _one(client, scene_path, frame_bodies, columns, moving, world, plan, profile) -> dict:
    """One frame kind: the HTTP call against MuJoCo on ``frame_bodies`` (medians in ms, the
    ratio, the pairs check, the profile)."""
    from impactnet.models.dispatch import Dispatcher
    from impactnet.models.frame import answer_frame
    from impactnet.training.bench.frame.mujoco_world import frame_call, world_model
    from impactnet.training.bench.speed import stages as st

    name = client.register_world(world) if world is not None else None
    at = _sent(columns, moving)

    def http_call(position, quaternion):
        return client.frame(at(position, quaternion), world=name)

    model, data, free = world_model(frame_bodies)
    theirs = frame_call(model, data, free)
    args = (frame_bodies.position.copy(), frame_bodies.quaternion.copy())
    ours = answer_frame(Dispatcher(), frame_bodies)
    a, b = ours.ids
    same = _ids(http_call(*args)) == set(zip(a.tolist(), b.tolist()))
    theirs.checked(*args)
    http_s, mujoco_s, calls = time_pair(http_call, theirs, args, plan)
    out = {"bodies_sent": moving, "pairs": int(len(ours.index)), "same_pairs": bool(same),
           "calls": calls, "http_ms": 1e3 * http_s, "mujoco_ms": 1e3 * mujoco_s,
           "ratio": http_s / mujoco_s}
    if profile:
        out["profile"] = st.profile("POST /v2/frame (npz)", "frame", 1,
                                    lambda: server_stages(scene_path, at(*args), world,
                                                          http_call, args),
                                    plan.profile_repeats)
    return out


def measure_http(yards: dict, plan: FramePlan, log=lambda message: None) -> dict:
    """Both frame kinds of every variant's yard over HTTP (module docstring); plain JSON
    types, or ``{"error": ...}`` where the server could not be measured."""
    from impactnet.training.bench.http.predictors import running_server

    out: dict = {"variants": {}}
    try:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "frame_bench.toml"
            path.write_text(worlds.scene_toml(), encoding="utf-8")
            with running_server(str(path), "none", log) as (client, info):
                for variant, found in yards.items():
                    every = found.frame(False)
                    entry = {
                        "everything": _one(client, str(path), every, worlds.columns(every),
                                           len(every), None, plan, True),
                        "spreader": _one(client, str(path), found.frame(True),
                                         worlds.columns(found.moving), len(found.moving),
                                         worlds.body_objects(found.world), plan, True)}
                    out["variants"][variant] = entry
                    log(f"  http {variant}: everything {entry['everything']['ratio']:.1f}x, "
                        f"spreader {entry['spreader']['ratio']:.1f}x MuJoCo")
            out["server"] = info
    except Exception as exc:  # noqa: BLE001 - the HTTP section fails alone, with the reason
        out["error"] = f"{type(exc).__name__}: {exc}"
    return out
