"""The speed section of ``impactnet bench`` (and ``impactnet bench speed`` alone): box pairs
against MuJoCo called from Python (:mod:`impactnet.training.bench.speed.box_pairs`) on the
scene's first contacts and the stacking families, and the per-stage profile of the box solver
and the compound oracle (:mod:`impactnet.training.bench.speed.stages`).

    from impactnet.training.bench.speed.section import QUICK_SPEED, measure, markdown
    speed = measure(QUICK_SPEED, scene_set, seed=0)   # plain JSON types
    print("\\n".join(markdown(speed)))
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from impactnet.training.bench.speed import box_pairs
from impactnet.training.bench.speed import stages as st

#: The compound oracle's profiled levels (labels of ``compound.detail.LEVELS``).
PROFILE_LEVELS = ("apertures (detail 2)", "twistlocks, 32 sides", "cell guide")


@dataclass(frozen=True)
class SpeedPlan:
    """How much the speed section measures; :data:`QUICK_SPEED` is the smoke-test plan."""

    pairs: int = 100_000  # batch N per pose set (MuJoCo: its whole blocks of 1,000)
    single_calls: int = 2_000  # N = 1: timed calls per side and pose set
    single_warmup: int = 100  # N = 1: untimed calls first, per side
    rounds: int = 3  # N = 1: alternating slices of the two sides
    repeats: int = 7  # batch: timed rounds (box_box all cores, one thread, MuJoCo)
    profile_repeats: int = 7  # stage profile: timed rounds
    profile_pairs: int = 100_000  # box solver profile: scene poses
    profile_poses: int = 1_000  # compound profile: poses per level (one oracle block at most)


QUICK_SPEED = SpeedPlan(pairs=10_000, single_calls=300, single_warmup=30, repeats=3,
                        profile_repeats=3, profile_pairs=10_000, profile_poses=30)


def _compound_profile(label: str, poses: int, seed: int, repeats: int) -> dict:
    from impactnet.training.bench.compound.detail import LEVELS, level_poses
    from impactnet.training.bench.speed.stage_sources import compound_stages

    _, detail, body_b, _, _ = next(level for level in LEVELS if level[0] == label)
    parts_a, parts_b, position, quaternion = level_poses(detail, body_b, poses, seed)
    origin, identity = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
    return st.profile(f"compound_answer, {label}", "pose", len(position),
                      lambda: compound_stages(parts_a, origin, identity, parts_b, position,
                                              quaternion), repeats)


def profiles(plan: SpeedPlan, scene_set, seed: int, log=lambda message: None) -> list[dict]:
    """The stage profiles: the box solver on the scene set's first poses, the compound oracle
    on :data:`PROFILE_LEVELS`."""
    from impactnet.training.bench.speed.stage_sources import box_stages

    args = scene_set.args(np.arange(min(plan.profile_pairs, len(scene_set))))
    out = [st.profile("box_box", "pair", len(args[0]), lambda: box_stages(args),
                      plan.profile_repeats)]
    for label in PROFILE_LEVELS:
        out.append(_compound_profile(label, plan.profile_poses, seed, plan.profile_repeats))
        log(f"  profile {label}: {out[-1].get('whole_us') or 0:.0f} us/pose")
    return out


def measure(plan: SpeedPlan, scene_set, seed: int, log=lambda message: None) -> dict:
    """The section's figures as plain JSON types: the box-pair families (scene set, stacking;
    None with the reason where MuJoCo is missing) and the profiles."""
    from impactnet.training.bench.accuracy.vs_mujoco import mujoco_missing
    from impactnet.training.bench.pose_sets import stacking_set

    box_pairs.warm_kernels(log)
    note = mujoco_missing()
    out = {"plan": asdict(plan), "mujoco": note, "families": None,
           "cores": box_pairs.usable_cores(), "kernel_threads": box_pairs.kernel_threads()}
    if note is None:
        import mujoco

        from impactnet.training.bench.speed.mujoco_calls import MODEL_PAIRS, ExplicitPairs

        out["mujoco"] = f"MuJoCo {mujoco.__version__}"
        out["model_pairs"] = MODEL_PAIRS
        model = ExplicitPairs()
        out["families"] = [box_pairs.measure(poses, plan, model, log)
                           for poses in (scene_set, stacking_set(plan.pairs, seed))]
    out["profiles"] = profiles(plan, scene_set, seed, log)
    return out


def markdown(speed: dict) -> list[str]:
    """The section's Markdown lines (title included)."""
    lines = ["## Speed against MuJoCo called from Python (issue #32)", "",
             f"Ratios are ours / MuJoCo, time per pair, both measured in this run (below 1x: "
             f"we are faster); {speed['cores']} usable cores, the kernels' default threads "
             f"{speed['kernel_threads']}. MuJoCo from Python, per call: write both bodies' "
             "qpos, `mj_kinematics`, `mj_collision`, copy the contacts' pos, frame and dist "
             "into arrays (the model built once, before timing). `box_box`, per call: the six "
             "inputs to the `Contacts` arrays, input checks included. MuJoCo's C rate: one "
             "model of 1,000 box pairs (2,000 free bodies) named in `<contact><pair>` "
             "elements, every geom with contype = conaffinity = 0, so the named pairs are the "
             "only candidates; sizes, qpos and `mj_kinematics` set untimed, then one "
             "`mj_collision` per 1,000 pairs timed.", ""]
    if speed["families"] is None:
        lines += [f"Not available: {speed['mujoco']}.", ""]
    else:
        for f in speed["families"]:
            lines += [f"- {f['pose_set']}: {f['description']}."]
        lines += [""] + box_pairs.tables(speed["families"]) + [""]
    lines += ["### Stage profile", "",
              "µs per pair or pose of each stage on prepared inputs (median over rounds); "
              "the whole is the public entry on the same inputs, and the rest what no stage "
              f"covers ({st.PART_OF.strip()}: part of the stage above, not summed). Sources: "
              "`training/bench/speed/stage_sources.py`.", "", st.table(speed["profiles"]), ""]
    return lines


def run(quick: bool, out, seed: int = 0, scene: str = "quay_crane", log=None) -> int:
    """``impactnet bench speed``: the section alone on the scene's first contacts; prints the
    Markdown and writes ``speed.md`` and ``speed.json`` into ``out``. Returns 0."""
    import datetime
    import json
    import sys
    import time

    from impactnet.models.scenes import load_scene
    from impactnet.training.bench.markdown import invoked_command, machine_line
    from impactnet.training.bench.pose_sets import scene_poses
    from impactnet.training.bench.timing import machine_info

    log = log or (lambda message: print(message, file=sys.stderr, flush=True))
    started = time.perf_counter()
    plan = QUICK_SPEED if quick else SpeedPlan()
    machine = machine_info()
    scene_set = scene_poses(load_scene(scene), plan.pairs, seed)
    results = {"created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
               "mode": "quick" if quick else "full", "seed": seed, "scene": scene,
               "command": invoked_command("impactnet bench speed" + (" --quick" if quick
                                                                     else "")),
               "machine": machine, "speed": measure(plan, scene_set, seed, log)}
    results["seconds"] = round(time.perf_counter() - started, 1)
    text = "\n".join([f"# impactnet bench speed ({results['mode']} run, {results['created']}, "
                      f"{results['seconds']} s)", "", f"Command: `{results['command']}`.", "",
                      f"Machine: {machine_line(machine)}.", "",
                      *markdown(results["speed"])])
    out.mkdir(parents=True, exist_ok=True)
    (out / "speed.md").write_text(text, encoding="utf-8")
    (out / "speed.json").write_text(json.dumps(results, indent=1, allow_nan=False),
                                    encoding="utf-8")
    print(text)
    log(f"impactnet bench speed: wrote {out / 'speed.md'}, {out / 'speed.json'}")
    return 0
