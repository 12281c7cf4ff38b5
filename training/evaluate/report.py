"""The Markdown report of `impactnet evaluate` (how to read it: docs/evaluation.md)."""
from __future__ import annotations

from impactnet.models.contacts import CONTACT_TYPES

#: Predictors in report order.
ORDER = ("exact", "single", "committee", "auto")
#: Paper problems in report order, with their headings.
PAPER_PROBLEMS = (("with_discontinuities", "with discontinuities (every contact; the goal)"),
                  ("without_discontinuities", "without discontinuities (one smooth region)"))


def _num(value, digits: int = 3, scale: float = 1.0) -> str:
    """A figure for a table cell; "-" where nothing was measured (None)."""
    if value is None:
        return "-"
    value = scale * value
    return f"{value:.{digits}g}" if abs(value) >= 1e4 or 0 < abs(value) < 1e-3 \
        else f"{value:.{digits}f}"


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |",
             "|" + "|".join("---" if i == 0 else "---:" for i in range(len(header))) + "|"]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def _ordered(mapping: dict) -> list[str]:
    return [n for n in ORDER if n in mapping]


def header(results: dict) -> list[str]:
    config, bundle = results["config"], results["bundle"]
    lines = [f"# Evaluation of bundle `{bundle['version']}` on scene `{results['scene']['name']}`",
             "", f"- Command: `{command(results)}`",
             f"- Test set: {config['rows']:,} fresh rows per body pair, "
             f"{len(results['pairs'])} pairs, seed {config['seed']} (a random stream no "
             "training run draws from); labels from the exact solver.",
             f"- Scene tolerance: normal {results['tolerance']['normal_deg']:g} deg, point "
             f"{results['tolerance']['point_pct']:g} % of e (e: the smaller body's shortest "
             f"edge). Run time {results['seconds']:.1f} s."]
    if config["quick"]:
        lines.append("- **Quick run** (smoke test): too few rows for the figures to mean much.")
    if not bundle["scene_matches"]:
        lines.append("- **The bundle was trained on another version of the scene** (hash "
                     "differs).")
    for name, reason in results["predictors"].items():
        if reason:
            lines.append(f"- `{name}` not available: {reason}")
    return lines + [""]


def command(results: dict) -> str:
    config = results["config"]
    parts = ["impactnet evaluate", f"--scene {results['scene']['name']}",
             f"--bundle {results['bundle']['path']}", f"--seed {config['seed']}"]
    parts.append("--quick" if config["quick"] else f"--rows {config['rows']}")
    return " ".join(parts)


def goals(results: dict) -> list[str]:
    rows = [[g["goal"], f"`{g['predictor']}`", f"{g['sense']} {g['bound']:g} {g['unit']}",
             _num(g["value"], 4), "met" if g["met"] else "**missed**"] for g in results["goals"]]
    verdict = "all met" if results["goals_met"] else "some missed"
    return [f"## Goals of issue 4 ({verdict})", "",
            *_table(["goal", "predictor", "bound", "measured", ""], rows), ""]


def predictor_table(block: dict) -> list[str]:
    """Counts, accuracies and error summaries of each predictor of one figures block."""
    rows = []
    for name in _ordered(block["predictors"]):
        s = block["predictors"][name]
        rows.append([f"`{name}`", f"{s['contacts']:,}", f"{s['missed_contacts']:,}",
                     f"{s['false_contacts']:,}", _num(s["type_accuracy"], 4),
                     _num(s["region_accuracy"], 4)]
                    + [_num(s["normal_deg"][k]) for k in ("median", "mean", "p95", "p99", "max")]
                    + [_num(s["point_pct"][k]) for k in ("median", "mean", "p95", "p99", "max")]
                    + [_num(s["depth_pct"][k]) for k in ("median", "p99")]
                    + [_num(s["depth_mm"][k]) for k in ("median", "p99", "max")]
                    + [_num(s.get("pairs_per_s"), 3, 1e-6)])
    header_ = ["predictor", "contacts", "missed", "false", "type acc", "region acc",
               "normal med", "mean", "p95", "p99", "max", "point med", "mean", "p95", "p99",
               "max", "depth % med", "p99", "depth mm med", "p99", "max", "M pairs/s"]
    return _table(header_, rows)


def pooled(results: dict) -> list[str]:
    block = results["pooled"]
    lines = ["## Every predictor, pooled over the scene", "",
             "Normal error in degrees, point and depth error in % of e, depth also in mm; "
             "errors on the rows both the exact solver and the predictor call colliding. "
             "`missed`: exact says contact, the predictor none; `false`: the other way round. "
             "Accuracies over all rows (\"none\" is a type and a region).", "",
             *predictor_table(block), ""]
    if block.get("excluded"):
        lines += [f"Not pooled (do not cover every pair): {', '.join(block['excluded'])}.", ""]
    return lines


def confusions(results: dict) -> list[str]:
    block = results["pooled"]
    lines = ["## Region and contact-type confusions", ""]
    for name in _ordered(block.get("mismatches", {})):
        m = block["mismatches"][name]
        if name == "exact" or m is None:
            continue
        lines += [f"`{name}`: {m['region_mismatches']:,} region mismatches: "
                  f"{m['type_mismatches']:,} of the contact type, "
                  f"{m['same_type_other_features']:,} of the same type with other features; "
                  f"{m['benign_within_tolerance']:,} benign (answer within the scene's "
                  f"tolerance: the same contact under another name, e.g. a symmetric "
                  f"relabelling); {m['near_boundary']:,} within 1e-3 e of a region boundary.",
                  ""]
        rows = [[c["pair"], f"`{c['exact']}`", f"`{c['predicted']}`", f"{c['rows']:,}",
                 _num(100 * c["share"], 3)] for c in block["top_confusions"].get(name, [])]
        if rows:
            lines += [f"Most frequent region confusions of `{name}` (world feature ids, "
                      "models/geometry/box_features.py):", "",
                      *_table(["pair", "exact", "predicted", "rows", "% of rows"], rows), ""]
    matrix = block["type_confusion"].get("committee")
    if matrix is not None:
        rows = [[CONTACT_TYPES[i]] + [f"{v:,}" for v in row] for i, row in enumerate(matrix)]
        lines += ["Contact types of `committee` (rows: exact, columns: predicted):", "",
                  *_table(["exact \\ predicted", *CONTACT_TYPES], rows), ""]
    return lines


def per_pair(results: dict) -> list[str]:
    rows = []
    for key, block in results["pairs"].items():
        s = block["predictors"]
        c, a = s.get("committee"), s.get("auto")
        rows.append([key, _num(c and c["region_accuracy"], 4),
                     _num(c and c["normal_deg"]["median"]), _num(c and c["normal_deg"]["mean"]),
                     _num(c and c["point_pct"]["median"]), _num(c and c["point_pct"]["mean"]),
                     _num(a and a["normal_deg"]["p99"]), _num(a and a["point_pct"]["p99"]),
                     _num(a and 100 * a["fallback_share"], 3)])
    auto = results["pooled"]["predictors"].get("auto")
    overall = f"{100 * auto['fallback_share']:.2f} %" if auto else "-"
    experts = []
    for key, block in results["pairs"].items():
        e = (block["predictors"].get("committee") or {}).get("experts")
        if e:
            experts.append([key, _num(e["share"] and 100 * e["share"], 1), _num(e["median"]),
                            _num(e["p90"]), _num(e["p99"])])
    return ["## Per pair", "", f"`auto` falls back to the exact solver on {overall} of all "
            "rows; per pair below (`committee`'s and `auto`'s key figures; full figures in "
            "evaluation.json).", "",
            *_table(["pair", "region acc", "normal med", "normal mean", "point med",
                     "point mean", "auto normal p99", "auto point p99", "auto fallback %"],
                    rows), "",
            "`committee`'s point error (% of e) where its experts answer: rows not sent to the "
            "exact solver whose point is not the exact one (edge-edge and aligned face rows "
            "take the exact point).", "",
            *_table(["pair", "expert rows %", "point med", "point p90", "point p99"], experts),
            ""]


def decisions(results: dict) -> list[str]:
    """Issue #21: which pairs the bundle serves learned, which exact-only, and why."""
    recorded = results.get("decisions") or {}
    if not any(recorded.values()):
        return ["## Served per pair", "", "The bundle records no per-pair decision (trained "
                "before issue #21): every pair is served by its learned models.", ""]
    rows = []
    for key, decision in recorded.items():
        if not decision:
            rows.append([key, "learned (no decision recorded)", *["-"] * 5])
            continue
        f = decision["figures"]
        rows.append([key, decision["serve"], f"{f['speedup_n1']:.2f}x",
                     f"{f['speedup_batch']:.2f}x at {f['poses']:,}",
                     f"{100 * f['fallback_share']:.1f} %", _num(f["normal_p99_deg"]),
                     _num(f["point_p99_fraction"] and 100 * f["point_p99_fraction"])])
    return ["## Served per pair", "",
            "Measured when the bundle was built (`impactnet.training.jobs.decisions`): a pair is "
            "served by its learned models only where `auto`, fallback included, is at least 2x "
            "faster than the exact solver at N = 1 and at the batch size and within tolerance. "
            "An exact-only pair is answered by the exact solver in every mode; the figures "
            "above are its learned models' (evaluated with the decisions lifted), what the "
            "decision weighed.", "",
            *_table(["pair", "served", "auto speed-up N = 1", "auto speed-up batch",
                     "auto fallback", "auto normal p99 (deg)", "auto point p99 (% of e)"], rows),
            ""]


def paper(results: dict) -> list[str]:
    block = results["paper"]
    lines = ["## The paper's four-angle metric on the paper's protocol", ""]
    if "skipped" in block:
        return lines + [f"Skipped: {block['skipped']}.", ""]
    lines += [f"Pair `{block['pair']}`; fresh external test sets of the paper's protocol "
              "(training/paper/data.py); errors in radians over all four angles, azimuths "
              "wrapped in the wrapped columns. The paper's Table 1 external MAE: 0.4523.", ""]
    for key, title in PAPER_PROBLEMS:
        problem = block["problems"].get(key)
        if problem is None:
            continue
        rows = []
        for name in _ordered(problem["predictors"]):
            m = problem["predictors"][name]
            rows.append([f"`{name}`", *(_num(m["raw"][k], 4) for k in ("ME", "MAE", "RMSE")),
                         *(_num(m["wrapped"][k], 4) for k in ("ME", "MAE", "RMSE")),
                         _num(m["normal_error_deg"]["mean"]),
                         _num(m["point_error_vs_exact_percent_of_edge"]["mean"]),
                         f"{m['predicted_separated']:,}"])
        lines += [f"{title}, {problem['rows']:,} rows:", "",
                  *_table(["predictor", "ME", "MAE", "RMSE", "wrapped ME", "wrapped MAE",
                           "wrapped RMSE", "normal mean deg", "point mean % (vs exact)",
                           "said none"], rows), ""]
    return lines


def boundary(results: dict) -> list[str]:
    bins = results["pooled"].get("boundary", {}).get("distance")
    if not bins:
        return []
    names = [n for n in _ordered(bins["predictors"]) if n != "exact"]
    rows = []
    for b, label in enumerate(bins["labels"]):
        row = [label, _num(100 * bins["share"][b], 3)]
        for name in names:
            f = bins["predictors"][name]
            row += [f"{_num(f['normal_deg_median'][b])} / {_num(f['normal_deg_p99'][b])}",
                    f"{_num(f['point_pct_median'][b])} / {_num(f['point_pct_p99'][b])}"]
        rows.append(row)
    header_ = ["distance (e)", "% of contacts"]
    for name in names:
        header_ += [f"`{name}` normal med / p99", f"`{name}` point med / p99"]
    return ["## Error against the distance to the nearest region boundary", "",
            "Distance: min(SAT margin, vertex gap) as a fraction of e (docs/evaluation.md); "
            "contact rows of the exact solver. evaluation.json also bins the SAT margin alone.",
            "", *_table(header_, rows), ""]


def figures(paths: list[str]) -> list[str]:
    titles = {"error_cdf.png": "Error CDFs per predictor",
              "boundary.png": "Error against the boundary distance",
              "confusion.png": "Contact-type confusion"}
    lines = ["## Figures", ""]
    for name in paths:
        lines += [f"![{titles.get(name, name)}]({name})", ""]
    return lines


def markdown(results: dict, figure_files: list[str]) -> str:
    """The whole report."""
    parts = (header(results), goals(results), pooled(results), confusions(results),
             per_pair(results), decisions(results), paper(results), boundary(results),
             figures(figure_files),
             ["Figures as JSON: evaluation.json. How to read this report: docs/evaluation.md.",
              ""])
    return "\n".join(line for part in parts for line in part)
