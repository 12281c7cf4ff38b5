"""The report of `impactnet bench moe` (:mod:`impactnet.training.bench.learned.moe`): markdown
tables and the plot of cost against detail."""
from __future__ import annotations

import numpy as np


def _pct(value) -> str:
    return "-" if value is None else f"{100 * value:.2f} %"


def _pair_lines(pairs: list[dict]) -> list[str]:
    lines = ["| pair | rows | exact sets (answered) | missed | fallback | coarse regions right | "
             "p99 depth / tol | p99 normal | p99 point / tol | oracle N = 1 | auto N = 1 | "
             "oracle batch | auto batch | speed-up N = 1 / batch | rule says | bundle records |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in pairs:
        m = row.get("measured")
        if m is None:
            lines.append(f"| {row['pair']} | {row['rows']} | no models | | | | | | | | | | | | "
                         f"exact-only | {row['recorded']} |")
            continue
        lines.append(
            f"| {row['pair']} | {m['rows']:,} | {_pct(m['exact_set_answered'])} | "
            f"{_pct(m['missed_share'])} | {_pct(m['fallback_share'])} | "
            f"{_pct(m['regions']['region_exact_share'])} | "
            f"{m['depth_p99_over_tolerance']:.2f} | {m['normal_p99_deg']:.3f}° | "
            f"{m['point_p99_over_tolerance']:.2f} | {m['oracle_n1_us']:,.0f} µs | "
            f"{m['auto_n1_us']:,.0f} µs | {m['oracle_batch_us_per_pose']:,.0f} µs | "
            f"{m['auto_batch_us_per_pose']:,.0f} µs | {m['speedup_n1']:.2f}x / "
            f"{m['speedup_batch']:.2f}x | {row['decision']} | {row['recorded']} |")
    return lines


def report(result: dict) -> str:
    """The markdown report."""
    config, machine = result["config"], result["machine"]
    timing = config["timing"]
    lines = [f"# The learned path of compound pairs against the oracle ({result['scene']})", "",
             f"Command: `{result.get('command', 'impactnet bench moe')}`.", "",
             f"Bundle `{result['version']}`; batch N = {timing['batch_poses']:,} (the rows "
             f"repeated), N = 1 the median of {timing['single_calls']} single calls; one "
             f"thread on {machine['cpu']} ({machine['cores']} cores, load "
             f"{machine['load_avg_1m']:.2f}); {result['seconds']:.0f} s. Batch costs are µs "
             "per pose. Tolerances: depth 2 % of the depth range, point 2 % of the smaller "
             "touching part's smallest extent; / tol <= 1 meets them.", ""]
    lines += _pair_lines(result["pairs"])
    for row in result["pairs"]:
        if row.get("reasons"):
            lines.append(f"\n- **{row['pair']}**: {'; '.join(row['reasons'])}.")
    if result["detail"]:
        lines += ["", "## Cost against detail (spreader on a 40 ft container)", "",
                  "| head sides | oracle batch | auto batch | classifiers batch | oracle N = 1 | "
                  "auto N = 1 | classifiers N = 1 |", "|---|---|---|---|---|---|---|"]
        for r in result["detail"]:
            lines.append(f"| {r['sides']} | {r['oracle_batch_us']:,.0f} | "
                         f"{r['auto_batch_us']:,.0f} | {r['classifier_batch_us']:,.1f} | "
                         f"{r['oracle_n1_us']:,.0f} | {r['auto_n1_us']:,.0f} | "
                         f"{r['classifier_n1_us']:,.0f} |")
    if result.get("http"):
        from impactnet.training.bench.http.moe import http_lines

        lines += http_lines(result["http"])
    return "\n".join(lines)


def plot_detail(rows: list[dict], path) -> None:
    """µs per pose (log) against the heads' sides: oracle, auto and the classifiers alone."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.6), dpi=120)
    sides = np.array([r["sides"] for r in rows])
    for key, label, style in (("oracle_batch_us", "oracle, batch", "o-"),
                              ("auto_batch_us", "auto (classifiers + exact part solver), batch",
                               "s-"),
                              ("classifier_batch_us", "classifiers alone, batch", "^-"),
                              ("oracle_n1_us", "oracle, N = 1", "o--"),
                              ("auto_n1_us", "auto, N = 1", "s--")):
        ax.plot(sides, [r[key] for r in rows], style, label=label)
    ax.set(xscale="log", yscale="log", xlabel="twistlock head sides",
           ylabel="µs per pose (one thread)",
           title="Spreader landing: cost against detail, learned path and oracle")
    ax.set_xticks(sides, [str(s) for s in sides])
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
