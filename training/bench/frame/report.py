"""The Markdown of ``impactnet bench frame`` (``frame.md``): goals, the scaling tables and fit,
the speed tables against MuJoCo, and the stage profiles. Only measured figures and what
follows from them arithmetically: no sentence that a rerun could make false."""
from __future__ import annotations

import math

from impactnet.training.bench.markdown import machine_line
from impactnet.training.bench.speed import stages as st
from impactnet.training.bench.speed.ratios import figure, goal_line, times, verdict

GOALS = {"in process": 2.0, "HTTP": 3.0}


def _ms(value: float | None) -> str:
    return figure(value)


def _goals(results: dict) -> list[str]:
    speed, http = results.get("speed", {}), results.get("http", {})
    lines = ["## Goals (issue #34), measured in this run", ""]
    if "error" in speed:
        return lines + [f"Not measured: {speed['error']}.", ""]
    for variant, entry in speed["variants"].items():
        f = entry["free"]
        lines.append("- " + goal_line(f"in process, every body free, {variant}",
                                      1e3 * f["ours_ms"], 1e3 * f["mujoco_ms"],
                                      GOALS["in process"]))
    for variant, entry in http.get("variants", {}).items():
        for kind, what in (("everything", "everything sent"),
                           ("spreader", "world registered, the spreader sent")):
            h = entry[kind]
            lines.append("- " + goal_line(f"HTTP (npz), {what}, {variant}", 1e3 * h["http_ms"],
                                          1e3 * h["mujoco_ms"], GOALS["HTTP"]))
    if "error" in http:
        lines.append(f"- HTTP: not measured ({http['error']})")
    return lines + [""]


def _scaling(scaling: dict, figure_path: str) -> list[str]:
    frames = scaling["frames"]
    variants = [v for v in ("boxes", "detail 2") if frames and v in frames[0]]
    lines = ["## Scaling (issue #34, item 4)", "",
             f"![time per frame against bodies]({figure_path})", "",
             "Whole frames on square yards, every body free (the stacks' contacts answered), "
             "margin 0; ms per frame, median after a warm-up call. Pairs found: the "
             "broadphase's; kept: the pairs that touch.", "",
             "| bodies | stacks (rows) | " + " | ".join(
                 f"{v}: pairs found / kept | {v}: broadphase ms | {v}: frame ms"
                 for v in variants) + " |",
             "|---:|---:|" + "---:|---:|---:|" * len(variants)]
    for r in frames:
        cells = [f"{r['bodies']:,}", f"{r['stacks']:,} ({r['rows']})"]
        for v in variants:
            p = r[v]
            cells += [f"{p['found']:,} / {p['kept']:,}", _ms(p["broadphase_ms"]),
                      _ms(p["ms"])]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "The broadphase alone (`body_pairs` on prepared envelopes and rotations), "
              "scene `quay_crane`'s yards laid out square or as a block; candidates: the "
              "pairs whose bounds overlap on the sweep's axis (what the sweep walks).", "",
              "| layout | bodies | rows | pairs found | candidates walked | ms | "
              "ns per n log2 n |", "|---|---:|---:|---:|---:|---:|---:|"]
    for layout, series in scaling["broadphase"].items():
        for p in series["points"]:
            per = 1e6 * p["ms"] / (p["bodies"] * math.log2(max(p["bodies"], 2)))
            lines.append(f"| {layout} | {p['bodies']:,} | {p['rows']} | {p['pairs']:,} | "
                         f"{p['candidates']:,} | {_ms(p['ms'])} | {per:.3g} |")
    lines += ["", *_fits(scaling), ""]
    return lines


def _slope(points: list[dict]) -> float:
    a, b = points[-2], points[-1]
    return math.log(b["ms"] / a["ms"]) / math.log(b["bodies"] / a["bodies"])


def _fits(scaling: dict) -> list[str]:
    lines = ["Fits of the broadphase's time, `t = c + a n log2 n + b x` in least relative "
             "squares with non-negative coefficients, over the yards of "
             f"{scaling['plan']['fit_from']:,} bodies and more:", ""]
    for layout, series in scaling["broadphase"].items():
        for key in ("fit_pairs", "fit_candidates"):
            f = series[key]
            lines.append(f"- {layout} yards, x = {f['x']}: c = {f['c_us']:.3g} µs, a = "
                         f"{f['a_ns']:.3g} ns, b = {f['b_ns']:.3g} ns; largest residual "
                         f"{100 * f['max_rel_residual']:.0f} % ({f['points']} yards)")
        points = series["points"]
        growth = points[-1]["candidates"] / max(points[-2]["candidates"], 1)
        lines.append(f"- {layout} yards, from {points[-2]['bodies']:,} to "
                     f"{points[-1]['bodies']:,} bodies: time x "
                     f"{points[-1]['ms'] / points[-2]['ms']:.3g} (local exponent "
                     f"{_slope(points):.2f}), pairs found x "
                     f"{points[-1]['pairs'] / max(points[-2]['pairs'], 1):.3g}, candidates x "
                     f"{growth:.3g}")
    return lines


def _speed_rows(results: dict) -> list[str]:
    speed, http = results["speed"], results.get("http", {})
    lines = ["| variant | frame | bodies sent | pairs (same as MuJoCo's) | MuJoCo contacts | "
             "ours ms | MuJoCo ms | ours / MuJoCo | goal |", "|---|---|---:|---|---:|---:|"
             "---:|---:|---|"]
    for variant, entry in speed["variants"].items():
        for kind, label in (("free", "in process, every body free"),
                            ("world", "in process, world static, spreader free")):
            f = entry[kind]
            goal = f"<= 2x: {verdict(f['ratio'], 2.0)}" if kind == "free" else "–"
            same = "yes" if f["pairs"]["same"] else (f"**no**: {f['pairs']['only_ours']} "
                                                     f"ours only, {f['pairs']['only_mujoco']}"
                                                     " MuJoCo's only")
            lines.append(f"| {variant} | {label} | {f['free_bodies'] if kind == 'free' else 1}"
                         f" | {f['pairs']['ours']:,} ({same}) | {f['contacts_mujoco']:,} | "
                         f"{_ms(f['ours_ms'])} | {_ms(f['mujoco_ms'])} | {times(f['ratio'])} "
                         f"| {goal} |")
        for kind, label in (("everything", "HTTP npz, everything sent"),
                            ("spreader", "HTTP npz, world registered, spreader sent")):
            h = http.get("variants", {}).get(variant, {}).get(kind)
            if h is None:
                continue
            lines.append(f"| {variant} | {label} | {h['bodies_sent']:,} | {h['pairs']:,} "
                         f"({'yes' if h['same_pairs'] else '**no**'}) | – | "
                         f"{_ms(h['http_ms'])} | {_ms(h['mujoco_ms'])} | {times(h['ratio'])}"
                         f" | <= 3x: {verdict(h['ratio'], 3.0)} |")
    return lines


def _speed(results: dict) -> list[str]:
    speed = results["speed"]
    plan = speed["plan"]
    lines = ["## Speed against MuJoCo called from Python (issue #34, item 5)", "",
             f"One frame of a yard of {plan['containers']} containers, a spreader landing on "
             f"the last stack and {4 * plan['guided_stacks']} cell guides, margin 0, per "
             "variant: `boxes` (scene `quay_crane`'s containers and spreader, the detail "
             "scene's cell guides), `detail 1` (containers with solid castings, MuJoCo's "
             "parity model: box parts), `detail 2` (scene `quay_crane_detail` as served: "
             "apertures, 32-sided twistlock heads). Ours: the arrays into `Bodies`, then "
             "`answer_frame` (exact); over HTTP the client's whole call (the request's npz "
             "built, POST /v2/frame, the answer read). MuJoCo "
             f"({results.get('mujoco', 'MuJoCo')}): qpos written, `mj_kinematics`, "
             "`mj_collision`, the contacts copied, the model built once, `multiccd` off (one "
             "contact per geom pair with a mesh, as in `impactnet bench speed`), every body "
             "free or the world welded. Medians of alternating slices in this run; ratios "
             "ours / MuJoCo (below 1x: we are faster).", "", *_speed_rows(results), ""]
    return lines


def _profiles(results: dict) -> list[str]:
    speed, http = results["speed"], results.get("http", {})
    profiles = [e["profile"] for e in speed["variants"].values()]
    lines = ["## Where the time goes", "",
             "µs per frame of each stage on prepared inputs (medians over rounds), the whole "
             "being the call timed above; the rest is what no stage covers (in process: the "
             "merge of the answers and the glue; over HTTP: the transport, the event loop, "
             "the lanes' thread hops). Sources: `training/bench/frame/stages.py`, "
             "`training/bench/frame/frame_http.py`.", "", st.table(profiles), ""]
    for p in profiles:
        if "stages" in p:
            name, us = max(((k, v) for k, v in p["stages"].items()), key=lambda kv: kv[1])
            lines.append(f"- {p['solver']}: the largest share is {name}, "
                         f"{100 * us / p['whole_us']:.0f} % of {_ms(p['whole_us'])} µs")
    http_profiles = [entry[kind]["profile"] | {"solver": f"POST /v2/frame, {variant}, "
                                                         f"{kind} sent"}
                     for variant, entry in http.get("variants", {}).items()
                     for kind in ("everything", "spreader") if "profile" in entry[kind]]
    if http_profiles:
        lines += ["", st.table(http_profiles)]
    return lines + [""]


def markdown(results: dict, figure_path: str) -> str:
    """The whole report; ``figure_path``: the scaling figure, relative to the report."""
    m = results["machine"]
    load_end = results.get("load_avg_1m_end")
    head = [f"# A frame in one call: scaling and speed against MuJoCo ({results['mode']} run)",
            "",
            f"Command: `{results['command']}`; {results['seconds']} s, {results['created']}. "
            f"Machine: {machine_line(m)}; load "
            f"{load_end if load_end is None else round(load_end, 2)} at the end; the compiled "
            f"kernels on {results['kernel_threads']} thread(s). "
            "Yards, timing and references: `impactnet.training.bench.frame`.", ""]
    out = head + _goals(results) + _scaling(results["scaling"], figure_path)
    if "error" not in results.get("speed", {"error": 1}):
        out += _speed(results) + _profiles(results)
    return "\n".join(out).rstrip() + "\n"
