"""Writes the paper reproduction's report: report.md, tables.json and Figures 5 and 6 (PNG)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from impactnet.training.paper.data import CANONICAL_REGION, OUTPUT_NAMES
from impactnet.training.paper.report_text import discussion_lines, header_lines
from impactnet.training.paper.reproduce import PAPER_TABLES, SET_NAMES

SET_TITLES = {"training": "Training", "cross_validation": "Cross-validation",
              "external_validation": "External validation"}
FIGURES = {"with_discontinuities": ("figure5_with_discontinuities.png", "Figure 5"),
           "without_discontinuities": ("figure6_without_discontinuities.png", "Figure 6")}
METRIC_NOTE = ("Errors are predicted - desired, in radians; ME, MAE and RMSE pool all 4 outputs "
               "of all patterns (N x 4 numbers per cell).")


def _finite(value):
    """``value`` with every non-finite float replaced by None (strict JSON has no NaN/Inf)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def command(config: dict, out: str) -> str:
    quick = " --quick" if config["quick"] else ""
    return f"impactnet reproduce-paper{quick} --out {out} --seed {config['seed']}"


def tables(results: dict, out: str) -> dict:
    """The JSON beside the report: every figure of its tables, keyed for scripts."""
    ours = {}
    for key, p in results["problems"].items():
        m = p["metrics"]
        ours[key] = {measure: {s: m[s][measure] for s in SET_NAMES} for measure in m[SET_NAMES[0]]}
        ours[key]["hyper_parameters"] = {
            "architecture": p["architecture"], "n_parameters": p["n_parameters"],
            "train_config": p["train_config"], "best_epoch": p["best_epoch"],
            "epochs_run": p["epochs_run"], "stopped_by": p["stopped_by"], "grid": p["grid"]}
        ours[key]["data"] = {"sizes": p["sizes"], **p["data"]}
        ours[key]["timings_s"] = p["timings_s"]
        ours[key]["figure"] = p["figure"]
    return {"command": command(results["config"], out), "quick": results["config"]["quick"],
            "seed": results["config"]["seed"], "metric_definition": METRIC_NOTE,
            "canonical_region": {"contact_type": "face-vertex", "feature_a": CANONICAL_REGION[1],
                                 "feature_b": CANONICAL_REGION[2]},
            "paper": PAPER_TABLES, "ours": ours, "diagnostics": results.get("diagnostics"),
            "versions": results["versions"],
            "total_seconds": results["total_seconds"]}


def plot_figure(path: Path, figure: dict, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    desired = np.asarray(figure["desired"])
    fig, ax = plt.subplots(figsize=(9, 3.6), dpi=110)
    ax.plot(desired, "-", color="black", lw=1.0, label="desired")
    ax.plot(np.asarray(figure["predicted"]), ".", color="tab:red", ms=4, label="predicted")
    ax.set(xlabel="pattern of the external validation set", ylabel="output 1: point azimuth (rad)",
           title=title)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _f(v: float) -> str:
    return f"{v:.4f}"


def _table(ours: dict, paper: dict | None) -> list[str]:
    head = "| | " + " | ".join(SET_TITLES.values())
    rule = "|---|---|---|---"
    if paper:
        head += " | " + " | ".join(f"Paper: {t}" for t in SET_TITLES.values())
        rule += "|---|---|---"
    lines = [head + " |", rule + "|"]
    for row in ("ME", "MAE", "RMSE"):
        cells = [_f(ours[s][row]) for s in SET_NAMES]
        if paper:
            cells += [_f(paper[s][row]) for s in SET_NAMES]
        lines.append(f"| {row} | " + " | ".join(cells) + " |")
    return lines


def _distribution_row(label: str, d: dict, unit: str) -> str:
    return (f"| {label} | {d['mean']:.2f}{unit} | {d['median']:.2f}{unit} | {d['p90']:.2f}{unit} "
            f"| {d['p95']:.2f}{unit} | {d['max']:.2f}{unit} |")


def _problem_sections(key: str, p: dict, t: dict) -> list[str]:
    m, ext = t["ours"][key], p["metrics"]["external_validation"]
    lines = [f"## {p['title']}", "", f"Network {p['architecture']} ({p['n_parameters']} weights);"
             f" sets {p['sizes'][0]:,} / {p['sizes'][1]:,} / {p['sizes'][2]:,}.", "",
             "Raw errors, laid out like the paper, ours beside the paper's:", ""]
    lines += _table(m["raw"], PAPER_TABLES[key]) + ["", "Azimuth errors wrapped into [-pi, pi):",
                                                    ""]
    lines += _table(m["wrapped"], None)
    lines += ["", f"Share of azimuth errors beyond +-pi (seam flips) on the external set: "
              f"{100 * ext['seam_share']:.2f}%.", "",
              "Per output, external validation (raw / wrapped):", "",
              "| output | ME | MAE | RMSE | ME wrapped | MAE wrapped | RMSE wrapped |",
              "|---|---|---|---|---|---|---|"]
    for name in OUTPUT_NAMES:
        r, w = ext["per_output_raw"][name], ext["per_output_wrapped"][name]
        lines.append(f"| {name} | {_f(r['ME'])} | {_f(r['MAE'])} | {_f(r['RMSE'])} | "
                     f"{_f(w['ME'])} | {_f(w['MAE'])} | {_f(w['RMSE'])} |")
    lines += ["", "Geometric meaning, external validation:", "",
              "| measure | mean | median | p90 | p95 | max |", "|---|---|---|---|---|---|",
              _distribution_row("normal angle error (degrees)", ext["normal_error_deg"], ""),
              _distribution_row("point error, % of edge (both on A's surface)",
                                ext["point_error_percent_of_edge"], "%"),
              _distribution_row("point error, % of edge (vs the exact centre of pressure)",
                                ext["point_error_vs_exact_percent_of_edge"], "%")]
    fname, fig = FIGURES[key]
    lines += ["", f"![{fig}]({fname})", "",
              f"{fig}: the first {len(p['figure']['desired'])} patterns of the external "
              "validation set, output 1 (point azimuth); solid line desired, dots predicted.", ""]
    return lines


def _hyper_sections(results: dict) -> list[str]:
    lines = ["## Hyper-parameters, seeds and timings", "",
             "Screening grid (each pair trained briefly from the same seed, early-stopped on the "
             "validation set; the lowest validation loss wins; the test set is never used):", ""]
    for key, p in results["problems"].items():
        lines += [f"**{key}** (validation loss = MSE of standardised targets)", "",
                  "| learning rate | momentum | validation loss | best epoch | epochs | seconds |",
                  "|---|---|---|---|---|---|"]
        lines += [f"| {g['learning_rate']:g} | {g['momentum']:g} | {g['val_loss']:.4f} | "
                  f"{g['best_epoch']} | {g['epochs']} | {g['seconds']:.1f} |" for g in p["grid"]]
        c, tm = p["train_config"], p["timings_s"]
        lines += ["", f"Final: learning rate {c['learning_rate']:g}, momentum {c['momentum']:g}, "
                  f"mini-batch {c['batch_size']}, at most {c['max_epochs']} epochs, patience "
                  f"{c['patience']}, time cap {c['time_limit_s']:g} s; best epoch "
                  f"{p['best_epoch']} of {p['epochs_run']} run (stopped by {p['stopped_by']}). "
                  f"Data seed {p['data']['seed']}, torch seed {c['seed']}. Timings: data "
                  f"{tm['data']:.1f} s, screening {tm['screening']:.1f} s, final training "
                  f"{tm['final_training']:.1f} s, evaluation {tm['evaluation']:.1f} s.", ""]
    v = results["versions"]
    lines += [f"Total wall-clock time {results['total_seconds']:.0f} s (numpy {v['numpy']}, torch "
              f"{v['torch']}, one torch thread, deterministic algorithms).", ""]
    return lines


def write(results: dict, out_dir: Path, out_label: str | None = None) -> dict:
    """Write report.md, tables.json and both PNGs into ``out_dir``; returns the JSON dict."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t = tables(results, out_label or str(out_dir))
    (out_dir / "tables.json").write_text(json.dumps(_finite(t), indent=1, allow_nan=False) + "\n")
    lines = header_lines(results, t)
    for key, p in results["problems"].items():
        fname, fig = FIGURES[key]
        subtitle = p["title"].split(": ")[-1]
        plot_figure(out_dir / fname, p["figure"], f"{fig} (reproduced): {subtitle}")
        lines += _problem_sections(key, p, t)
    lines += discussion_lines(results, t) + _hyper_sections(results)
    (out_dir / "report.md").write_text("\n".join(lines))
    return t
