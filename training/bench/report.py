"""The benchmark's Markdown report and JSON file (the same figures)."""
from __future__ import annotations

import json
from pathlib import Path

from impactnet.training.bench.markdown import DASH, machine_line, significant

#: Pose set titles in the report.
SET_TITLES = {"scene": "Scene first contacts", "figure2": "Figure 2 hard case"}


def _ratio(x) -> str:
    return DASH if x is None else f"{x:.2g}x" if x < 10 else f"{x:,.0f}x"


def _pair(a, b) -> str:
    return f"{significant(a)} / {significant(b)}"


def method_table(rows: list[dict], pose_set: str) -> str:
    """One line per method on ``pose_set``."""
    lines = ["| method | N = 1: µs/call | vs exact | N measured | pairs/s | µs/pair | vs exact "
             "| normal error ° median / p99 | point error % median / p99 | type accuracy "
             "| within tolerance | vs MuJoCo: within 1° & 2 % | missed |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in (r for r in rows if r["pose_set"] == pose_set):
        if r["status"] != "ok":
            lines.append(f"| {r['method']} | {r['status']} |" + f" {DASH} |" * 11)
            continue
        e = r["errors"]
        n = f"{r['batch_n']:,}" + (" (subsample)" if r["batch_n"] < r["set_size"] else "")
        accuracy, within = (DASH if e[k] is None else f"{100 * e[k]:.2f} %"
                            for k in ("type_accuracy", "within_tolerance"))
        lines.append(
            f"| {r['method']} | {significant(r['us_n1'])} | {_ratio(r['n1_vs_exact'])} | {n} | "
            f"{r['pairs_per_s']:,.0f} | {significant(r['us_per_pair'])} | "
            f"{_ratio(r['per_pair_vs_exact'])} | "
            f"{_pair(e['normal_deg_median'], e['normal_deg_p99'])} | "
            f"{_pair(e['point_pct_median'], e['point_pct_p99'])} | {accuracy} | {within} | "
            f"{_mujoco_within(r.get('vs_mujoco'))} | {e['missed']:,} of {e['contacts']:,} |")
    return "\n".join(lines + _answered_by(rows, pose_set))


def _mujoco_within(summary: dict | None) -> str:
    if not summary or summary.get("within") is None:
        return DASH
    return f"{100 * summary['within']:.2f} %"


def mujoco_table(rows: list[dict], pose_set: str) -> str:
    """Each method against MuJoCo and the grid centre of pressure
    (impactnet.training.bench.accuracy.vs_mujoco)."""
    lines = ["| method | poses compared | within 1° & 2 % | normal error ° median / p99 "
             "| point error % median / p99 | MuJoCo edge-edge | missed |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        m = r.get("vs_mujoco")
        if r["pose_set"] != pose_set or r["status"] != "ok" or not m:
            continue
        lines.append(f"| {r['method']} | {m['rows']:,} | {_mujoco_within(m)} | "
                     f"{_pair(m['normal_deg_median'], m['normal_deg_p99'])} | "
                     f"{_pair(m['point_pct_median'], m['point_pct_p99'])} | "
                     f"{m['edge_rows']:,} | {m['missed']:,} of {m['mujoco_contacts']:,} |")
    return "\n".join(lines)


def mujoco_section(results: dict, pose_set: str) -> list[str]:
    """The "vs MuJoCo" paragraph and table of a pose set, or the note why it is missing."""
    info = results.get("mujoco")
    if not info:
        return []
    if not info["available"]:
        return [f"vs MuJoCo: not available: {info['note']}.", ""]
    return [f"Against independent references (MuJoCo {info.get('version')} box-box for the "
            f"normal; the grid centre of pressure, or MuJoCo's crossing point for its "
            f"edge-edge contacts, for the point; up to {info['rows']:,} of each method's "
            f"poses): share within {info['normal_deg']:g}° and {info['point_pct']:g} % of the "
            "shortest edge, errors against them.", "", mujoco_table(results["rows"], pose_set),
            ""]


def _answered_by(rows: list[dict], pose_set: str) -> list[str]:
    """A note per method whose pairs were answered by more than one predictor (auto)."""
    notes = []
    for r in rows:
        counts = r["info"].get("answered_by", {}) if r["pose_set"] == pose_set else {}
        if len(counts) > 1:
            total = sum(counts.values())
            shares = ", ".join(f"{k} {100 * v / total:.1f} %" for k, v in sorted(counts.items()))
            notes.append(f"- {r['method']}: answered by {shares} of the pairs.")
    return [""] + notes if notes else []


def polygon_table(paper: dict) -> str:
    """The polygon sweep against n, with the paper's bound sqrt(2)/n."""
    lines = ["| pose set | n | triangles per box | N = 1: µs/call | µs/pair (loop) "
             "| contacts per pair (median) | point error % median / p99 "
             "| paper bound √2/n % | within bound | normal error ° median / p99 | missed |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for b in paper["by_n"]:
        within = DASH if b["within_cell_diagonal"] is None else \
            f"{100 * b['within_cell_diagonal']:.1f} %"
        lines.append(
            f"| {b['pose_set']} | {b['n']} | {b['triangles_per_box']:,} | "
            f"{significant(b['us_n1'])} | "
            f"{significant(b['us_per_pair'])} | {significant(b['contacts_per_pair_median'])} | "
            f"{_pair(b['point_pct_median'], b['point_pct_p99'])} | "
            f"{significant(b['paper_bound_pct'])} | {within} | "
            f"{_pair(b['normal_deg_median'], b['normal_deg_p99'])} | "
            f"{100 * b['miss_rate']:.2g} % |")
    return "\n".join(lines)


def targets_table(paper: dict) -> str:
    """For each precision r: the paper's n(r) and the smallest measured n that reaches it."""
    sets = paper["pose_sets"]
    head = "| r | paper: n = E[√2/r] + 1 | triangles per face |" + "".join(
        f" {s}: n for median ≤ r | {s}: n for p99 ≤ r |" for s in sets)
    lines = [head, "|---:" * (3 + 2 * len(sets)) + "|"]
    for t in paper["targets"]:
        cells = [f"{100 * t['r']:g} %", str(t["paper_n"]), f"{t['paper_triangles_per_face']:,}"]
        for s in sets:
            for key in (f"{s}_median_n", f"{s}_p99_n"):
                cells.append(DASH + " (not reached)" if t[key] is None else str(t[key]))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def variants_table(rows: list[dict]) -> str:
    """The polygon reductions at the largest grid of each pose set."""
    lines = ["| pose set | n | reduction | normal error ° median / p99 "
             "| point error % median / p99 |", "|---|---:|---|---:|---:|"]
    polygon = [r for r in rows if r["family"] == "polygon" and r["status"] == "ok"]
    for pose_set in dict.fromkeys(r["pose_set"] for r in polygon):
        mine = [r for r in polygon if r["pose_set"] == pose_set]
        for row in (min(mine, key=lambda r: r["info"]["grid"]),
                    max(mine, key=lambda r: r["info"]["grid"])):
            for name, e in row["info"]["rule_variants"].items():
                lines.append(f"| {pose_set} | {row['info']['grid']} | {name} | "
                             f"{_pair(e['normal_deg_median'], e['normal_deg_p99'])} | "
                             f"{_pair(e['point_pct_median'], e['point_pct_p99'])} |")
    return "\n".join(lines)


def markdown(results: dict) -> str:
    """The whole report."""
    out = [f"# impactnet bench ({results['mode']} run, {results['created']}, "
           f"{results['seconds']} s)", "",
           f"Command: `{results.get('command', 'impactnet bench')}`.", "",
           f"Machine: {machine_line(results['machine'])}.", "",
           f"Polygon rule: {results['polygon_rule']}.", ""]
    tol = results["scene"].get("tolerance")
    if tol:
        out += [f"Within tolerance: the share of contacts answered within the scene's accuracy "
                f"(normal {tol['normal_deg']:g}°, point {tol['point_pct']:g} % of the shortest "
                "edge); a miss is outside.", ""]
    for name, pose_set in results["pose_sets"].items():
        out += [f"## {SET_TITLES.get(name, name)} ({pose_set['poses']:,} poses)", "",
                f"{pose_set['description']}.", "", method_table(results["rows"], name), ""]
        out += mujoco_section(results, name)
    paper = results["paper_estimate"]
    out += ["## Polygon method against n, and the paper's grid estimate", "",
            f"Reading of Section II: {paper['reading']}.", "", polygon_table(paper), "",
            targets_table(paper), "", paper["note"] + ".", "",
            "### Other reductions of the same triangle-pair contacts", "",
            variants_table(results["rows"]), ""]
    if results.get("speed"):
        from impactnet.training.bench.speed.section import markdown as speed_markdown

        out += speed_markdown(results["speed"])
    if "http" in results:
        from impactnet.training.bench.http.predictors import http_table

        out += ["## Through the HTTP service (loopback)", "", http_table(results["http"]), ""]
    return "\n".join(out)


def write(results: dict, out: Path) -> list[Path]:
    """Write ``results.md``, ``results.json`` and the figures into ``out``; returns the paths."""
    from impactnet.training.bench import plots

    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "results.md", out / "results.json"]
    paths[0].write_text(markdown(results), encoding="utf-8")
    paths[1].write_text(json.dumps(results, indent=1, allow_nan=False), encoding="utf-8")
    paths += plots.write_all(results, out)
    return paths
