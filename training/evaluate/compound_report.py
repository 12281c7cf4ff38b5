"""The report of `impactnet evaluate` on a compound scene
(:mod:`impactnet.training.evaluate.compound`)."""
from __future__ import annotations

import json
from pathlib import Path


def _pct(value) -> str:
    return "-" if value is None else f"{100 * value:.2f} %"


def _x(value) -> str:
    return "-" if value is None else f"{value:.2f}x"


def markdown(result: dict) -> str:
    """The report as markdown: the decision table, the fresh scores, the experts."""
    lines = [f"# Evaluation of the compound pairs: {result['scene']}", "",
             f"Bundle `{result['version']}`; {result['rows_per_pair']:,} freshly labelled "
             f"first-contact rows per pair (seed {result['seed']}, a stream training never "
             f"uses); {result['seconds']:.0f} s. Command: `impactnet evaluate --scene "
             f"{result['scene']}`.", "",
             "## Served per pair: the decision and the figures behind it", "",
             "| pair | serves | speed-up N = 1 | speed-up batch | batch | reasons |",
             "|---|---|---|---|---|---|"]
    for p in result["pairs"]:
        r = p.get("recorded") or {}
        lines.append(f"| {p['pair']} | {p['serve']} | {_x(r.get('speedup_n1'))} | "
                     f"{_x(r.get('speedup_batch'))} | {r.get('batch_poses') or '-'} | "
                     f"{'; '.join(p.get('reasons') or []) or 'every goal met'} |")
    lines += ["", "## The learned path on fresh rows (decisions lifted)", "",
              "Goals (issue #21): exact sets on >= 99.9 % of answered rows, missed contacts "
              "<= 0.01 % of all rows, fallback <= 10 %, p99 errors within tolerance "
              "(/ tol <= 1).", "",
              "| pair | rows | answered by | exact sets (answered) | missed | fallback | "
              "coarse regions right | p99 depth / tol | p99 normal | p99 point / tol | goals |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for p in result["pairs"]:
        f = p.get("scored")
        if f is None:
            lines.append(f"| {p['pair']} | - | no models | | | | | | | | |")
            continue
        missed = [k for k, ok in p["goals"].items() if not ok]
        lines.append(f"| {p['pair']} | {f['rows']:,} | {f['answered_by']} | "
                     f"{_pct(f['exact_set_answered'])} | {_pct(f['missed_share'])} | "
                     f"{_pct(f['fallback_share'])} | "
                     f"{_pct(f['regions']['region_exact_share'])} | "
                     f"{f['depth_p99_over_tolerance']:.2f} | "
                     f"{f['normal_p99_deg']:.3f}° | {f['point_p99_over_tolerance']:.2f} | "
                     f"{'met' if not missed else 'missed: ' + ', '.join(missed)} |")
    lines += ["", "## Experts: the committees closest to the tolerance", "",
              "| pair | region | p99 depth / tol | p99 normal / tol | p99 point / tol | "
              "expert chosen |", "|---|---|---|---|---|---|"]
    for p in result["pairs"]:
        for r in p.get("best_regions", []):
            t = r["p99_over_tolerance"]
            lines.append(f"| {p['pair']} | {r['region']} | {t['depth']:.2f} | "
                         f"{t['normal']:.2f} | {t['point']:.2f} | {r['expert']} |")
    return "\n".join(lines)


def write(result: dict, out) -> list[Path]:
    """``report.md`` and ``evaluation.json`` in ``out``."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "report.md").write_text(markdown(result) + "\n", encoding="utf-8")
    (folder / "evaluation.json").write_text(json.dumps(result, indent=2, default=str) + "\n",
                                            encoding="utf-8")
    return [folder / "report.md", folder / "evaluation.json"]
