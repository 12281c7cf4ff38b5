"""The prose of the paper reproduction's report: header, protocol, summary and discussion.

Every number in it comes from the run's results; only the explanations are fixed text.
"""
from __future__ import annotations

import math

from impactnet.models.geometry import box_features as bf
from impactnet.training.paper.data import CANONICAL_REGION
from impactnet.training.paper.reproduce import PAPER_TABLES

#: Mean range of the four outputs (2 pi, pi, 2 pi, pi), radians: the paper's yardstick.
MEAN_OUTPUT_RANGE = 1.5 * math.pi

#: Band around the paper's MAE inside which the reproduction counts as agreeing (fraction).
AGREEMENT_BAND = 0.30


def _ratio(ours: float, paper: float) -> str:
    return f"{ours / paper:.2f}x"


def header_lines(results: dict, t: dict) -> list[str]:
    config = results["config"]
    lines = ["# The paper reproduced: Tables 1 and 2, Figures 5 and 6", "",
             f"Regenerate with `{t['command']}` (from the repository root; without the CLI "
             "wiring: `" + t["command"].replace("impactnet reproduce-paper",
                                                "python -m impactnet.training.paper.cli")
             + "`). "
             f"This run took {results['total_seconds']:.0f} s of wall-clock time.", ""]
    if config["quick"]:
        lines += ["**Quick run**: smoke-test sizes and a few epochs. These figures say nothing "
                  "about the paper; run without `--quick` for the reproduction.", ""]
    lines += ["## Summary", "",
              "| problem | MAE external, ours | paper | ours / paper | MAE external, wrapped "
              "azimuths | normal error (mean, degrees) | point error (mean, % of edge) |",
              "|---|---|---|---|---|---|---|"]
    for key, m in t["ours"].items():
        ours, paper = m["raw"]["external_validation"]["MAE"], \
            PAPER_TABLES[key]["external_validation"]["MAE"]
        lines.append(
            f"| {key.replace('_', ' ')} | {ours:.4f} | {paper:.4f} | {_ratio(ours, paper)} | "
            f"{m['wrapped']['external_validation']['MAE']:.4f} | "
            f"{m['normal_error_deg']['external_validation']['mean']:.2f} | "
            f"{m['point_error_percent_of_edge']['external_validation']['mean']:.2f}% |")
    lines += ["", *protocol_lines(results, t)]
    return lines


def protocol_lines(results: dict, t: dict) -> list[str]:
    config = results["config"]
    region = results["problems"].get("without_discontinuities", {}).get("data", {})
    stats = region.get("region_stats", {})
    depth = config["data"]["depth_fraction"]
    _, fa, fb = CANONICAL_REGION
    lines = ["## Protocol", "",
             f"* Two cubes of edge {config['data']['edge']:g} m (the paper's). B's orientation "
             "relative to A: roll, pitch, yaw each uniform in [-pi/2, pi/2], "
             "R = Rz(yaw) Ry(pitch) Rx(roll) (the paper names no convention; impactnet reads it "
             "as \"zyx\"). A random approach direction, uniform on the sphere; B moved along it "
             "to first touch (exact touching distance), then pushed in by a depth uniform in "
             f"[{depth[0]:g}, {depth[1]:g}] x edge "
             f"(`impactnet.models.geometry.poses.first_contact_poses`, "
             "`orientation=\"paper\"`). A sits at the origin with identity orientation.",
             "* Inputs (6): B's centre in A's frame (x, y, z in metres) and B's Euler angles "
             "relative to A (roll, pitch, yaw in radians). Outputs (4): azimuth and elevation of "
             "the impact point's direction from A's centre, then of the force direction (the "
             "contact normal, from A towards B), both in A's frame; azimuth = atan2(y, x) in "
             "[-pi, pi], elevation in [-pi/2, pi/2] (`impactnet.models.geometry.spherical`). "
             "Labels come from the "
             "exact solver (`impactnet.models.box.exact.box_box`); the impact point is its centre "
             "of pressure "
             "(docs/design.md, point rule v2).",
             "* **With discontinuities**: every contact of that stream (all contact types and "
             "features).",
             f"* **Without discontinuities**: one discontinuity-free region, contact type "
             f"face-vertex with feature_a = {fa} ({bf.feature_name(fa)} of A) and feature_b = "
             f"{fb} ({bf.feature_name(fb)} of B): B's corner on A's +x face. Every pattern of "
             "all three sets has exactly this label. Inside the region the impact point is the "
             "centre of pressure of the small footprint around B's corner (within the depth of "
             "the corner), a smooth function of the pose, "
             "and the force direction is A's +x normal, so outputs 3 and 4 are the constants "
             "0 and 0. The +x face was chosen over +z because on +z the point's azimuth would "
             "cross the +-pi seam and the normal would sit on the pole, where the azimuth is "
             "undefined; on +x the point azimuth stays in [-pi/4, pi/4].",
             ]
    if stats:
        drawn = stats["drawn"]
        lines.append(
            f"  It is drawn by rejection from the same stream: of {drawn:,} pairs drawn, "
            f"{stats['canonical']:,} ({100 * stats['canonical'] / drawn:.2f}%) were in the "
            f"region itself and {stats['mirrored']:,} ({100 * stats['mirrored'] / drawn:.2f}%) "
            "in it or one of its 8 mirror images (A's face +-x against the B corner on the "
            "opposite x side). The mirror images are folded onto the region by the sign flip "
            "S = diag(s) applied to both boxes (t -> S t, R -> S R S, i.e. (roll, pitch, yaw) "
            "-> (s1 s2 roll, s0 s2 pitch, s0 s1 yaw)), which leaves the whole sampling "
            "distribution unchanged, and are labelled again by the exact solver; "
            f"{stats['dropped']} folded rows left the region (boundary ties) and were dropped. "
            "So the set is distributed as the paper's stream conditioned on the region, at 8x "
            "the yield. For comparison, the paper split each cube into two trihedra and "
            "modelled trihedron against trihedron; its subsets are not specified further.")
    lines += ["* Sets: training / validation (the paper's \"cross-validation\", used for early "
              "stopping and the learning-rate/momentum choice) / external test, sizes as in the "
              "paper, consecutive slices of one seeded stream.",
              "* Network as in the paper: 6x20x18x4 (with) and 6x20x17x4 (without), tanh hidden "
              "units, linear outputs, backpropagation (`torch.optim.SGD` with momentum, "
              "mini-batches) on the mean squared error of the standardised targets; inputs and "
              "targets standardised with training-set statistics; early stopping on the "
              "validation set with the best weights restored.",
              f"* Metrics: {t['metric_definition']} The paper does not define the sign of its "
              "errors; ours is predicted - desired (only ME depends on it).", ""]
    return lines


def discussion_lines(results: dict, t: dict) -> list[str]:
    ours = {k: m["raw"]["external_validation"]["MAE"] for k, m in t["ours"].items()}
    paper = {k: PAPER_TABLES[k]["external_validation"]["MAE"] for k in ours}
    lines = ["## Reading the results", ""]
    for key in ours:
        inside = abs(ours[key] / paper[key] - 1.0) <= AGREEMENT_BAND
        lines.append(f"* {key.replace('_', ' ')}: external MAE {ours[key]:.4f} against the "
                     f"paper's {paper[key]:.4f} ({_ratio(ours[key], paper[key])}), "
                     + ("within" if inside else "**outside**")
                     + f" the +-{100 * AGREEMENT_BAND:.0f}% band; that is "
                     f"{100 * ours[key] / MEAN_OUTPUT_RANGE:.1f}% of the mean output range "
                     "(3 pi / 2; the paper reports \"near 10 %\").")
    lines += ["* The paper's text says that the model without discontinuities did \"obviously "
              "better\", yet its Table 2 (without) has larger errors than its Table 1 (with) in "
              "every cell but the external ME. Either the tables are swapped or the text is "
              "wrong; the paper gives no way to tell, so both are shown here as printed."]
    key = "with_discontinuities"
    if key in t["ours"]:
        raw = t["ours"][key]["raw"]
        ratio = raw["external_validation"]["MAE"] / raw["training"]["MAE"]
        p = PAPER_TABLES[key]
        paper_ratio = p["external_validation"]["MAE"] / p["training"]["MAE"]
        lines.append(
            f"* Table 1: our three sets are independent draws of one distribution, so the "
            f"external MAE is {ratio:.2f}x the training MAE; in the paper it is "
            f"{paper_ratio:.2f}x, which suggests that its external set was drawn differently "
            "from its training set (or that its network over-fitted). The raw errors are "
            "dominated by the two azimuths (per-output table): the point and force directions "
            "jump between faces, edges and corners, and the azimuth label jumps across its "
            "+-pi seam; wrapping removes only the latter.")
    lines += ["", *_diagnostic_lines(results, ours, paper)]
    return lines


def _diagnostic_lines(results: dict, ours: dict, paper: dict) -> list[str]:
    diag = results.get("diagnostics")
    key = "without_discontinuities"
    if not diag or key not in ours:
        return []
    region = results["problems"][key]["metrics"]["external_validation"]
    lines = ["## Why Table 2 is far off: from one region to wider families", "",
             "Our \"without discontinuities\" problem is one region, in which the force "
             "direction is a constant (A's +x normal: outputs 3 and 4 are constant labels) and the "
             "point a smooth function of the pose, so the paper's small network learns it "
             f"almost exactly (mean point error "
             f"{region['point_error_percent_of_edge']['mean']:.2f}% of the edge). The paper's "
             "Table 2 instead has errors of about 0.5 rad, balanced over its four outputs, which "
             "no region with a constant force direction can produce. To see which data could "
             f"give such errors, the same network ({diag['architecture']}, Table 2's learning "
             "rate and momentum) was trained on wider families cut from one more stream "
             f"({diag['draws']:,} pairs, seed {diag['seed']}, sets "
             f"{diag['sizes'][0]:,} / {diag['sizes'][1]:,} / {diag['sizes'][2]:,}):", "",
             "| data | regions | share of the stream | external MAE | wrapped | per-output MAE, "
             "wrapped | normal error (mean, degrees) | point error (mean, % of edge) |",
             "|---|---|---|---|---|---|---|---|"]

    def row(title, regions, share, m, per, normal, point):
        return (f"| {title} | {regions} | {share} | {m['raw']['MAE']:.4f} | "
                f"{m['wrapped']['MAE']:.4f} | {' / '.join(f'{v:.3f}' for v in per)} | "
                f"{normal:.2f} | {point:.2f}% |")

    def main_row(k, title, share):
        m = results["problems"][k]["metrics"]["external_validation"]
        per = [v["MAE"] for v in m["per_output_wrapped"].values()]
        return row(title, results["problems"][k]["data"]["regions"], share, m, per,
                   m["normal_error_deg"]["mean"], m["point_error_percent_of_edge"]["mean"])

    stats = results["problems"][key]["data"].get("region_stats", {})
    share = f"{100 * stats['canonical'] / stats['drawn']:.2f}%" if stats else "-"
    lines.append(main_row(key, "one region (Table 2, ours)", share))
    for d in diag["rows"]:
        lines.append(row(d["title"], d["regions"], f"{100 * d['share']:.1f}%", d,
                         d["per_output_mae_wrapped"], d["normal_error_deg_mean"],
                         d["point_error_percent_mean"]))
    if "with_discontinuities" in results["problems"]:
        lines.append(main_row("with_discontinuities", "every contact (Table 1, ours)", "100%"))
    every = ours.get("with_discontinuities")
    candidates = [(d["raw"]["MAE"], d["title"]) for d in diag["rows"]]
    if every is not None:
        candidates.append((every, "every contact"))
    largest, largest_title = max(candidates)
    capped = [d["title"] for d in diag["rows"] if d["stopped_by"] != "early stopping"]
    if capped:
        lines += ["", f"(Diagnostic runs stopped by their budget rather than by early stopping, "
                  f"so slightly pessimistic: {'; '.join(capped)}.)"]
    lines += ["", "The error grows as the data widen from one region to families of many regions "
              "(and so of discontinuities between them). "]
    if largest < (1.0 - AGREEMENT_BAND) * paper[key]:
        lines[-1] += (f"Yet the largest external MAE here is {largest:.4f} ({largest_title}), "
                      f"well below the paper's Table 2 external MAE of {paper[key]:.4f}: no "
                      "restriction of this protocol to a subset reproduces Table 2, so its "
                      "numbers must come from a different data protocol, output definition or "
                      "training than the paper describes (or be mislabelled, see above). We "
                      "report the gap rather than tune towards it.")
    else:
        lines[-1] += (f"The largest, {largest:.4f} ({largest_title}), is comparable to the paper's "
                      f"{paper[key]:.4f}: the paper's subsets may have been families of several "
                      "regions rather than one region.")
    lines.append("")
    return lines
