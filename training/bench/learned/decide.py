"""Model only what a scene requires, measured pair by pair (issue #21, step 4, for box pairs).

For every pair of a box scene, on the same first-contact poses of that pair
(:func:`impactnet.training.bench.pose_sets.scene_poses`), the exact solver and the shipped
bundle's ``auto`` mode (its fallback rows to the exact solver included) are timed at N = 1
(median of single-pair calls) and at the batch size (median of repeated calls), and ``auto`` is
scored against the exact answers at the scene's tolerance. The decision rule is the issue's: a
pair is *learned* only where ``auto`` is at least :data:`SPEEDUP_REQUIRED` x faster than the
exact solver at both sizes, its p99 normal and point errors meet the scene's ``[accuracy]`` on
those poses and wherever the validation gate measures the learned path (:data:`GATE_FIGURES`:
the pair's held-out test split, recorded in the bundle, and, when ``impactnet train`` decides,
fresh rows through the served predictor), and it misses no contact; otherwise it is
*exact-only*, with one plain reason per missed goal naming the figure and its limit
(:func:`serve_decision`, the one copy of the rule). Every figure behind the decision is
reported.

    impactnet bench decide --scene quay_crane [--quick] [--out DIR]

``impactnet train`` takes the same measurement when it builds a bundle and records each pair's
decision in it (:mod:`impactnet.training.jobs.decisions`); the service then answers an
exact-only pair through the exact solver in every mode. This command measures the learned path
of a bundle as it stands (recorded decisions lifted) and shows the recorded ones beside.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from impactnet.training.bench.accuracy.errors import method_summary, row_errors
from impactnet.training.bench.methods import exact_method, learned_bundle, predictor_method
from impactnet.training.bench.pose_sets import scene_poses
from impactnet.training.bench.timing import machine_info, median_per_call, median_repeated

#: The issue's rule: ``auto`` must be at least this many times faster than the exact solver, at
#: N = 1 and at the batch size, for a pair to be served by a learned model.
SPEEDUP_REQUIRED = 2.0


@dataclass(frozen=True)
class DecideConfig:
    """How much to measure; :data:`QUICK` is the smoke-test plan."""

    scene: str = "quay_crane"  # scene name or TOML path (box pairs only)
    poses_per_pair: int = 100_000  # the batch size N, per pair (the N = 1e5)
    single_calls: int = 1_000  # N = 1: timed calls per predictor and pair
    warmup: int = 50  # N = 1: untimed calls first
    repeats: int = 5  # batch: timed calls per predictor and pair
    seed: int = 0  # pose seed
    bundle: str | None = None  # bundle folder of `auto` (None: the scene's shipped one)


QUICK = DecideConfig(poses_per_pair=2_000, single_calls=100, warmup=10, repeats=2)


#: The learned path's accuracy figures the validation gate reads, as a decision row holds them
#: (key -> where, in the reasons): the held-out test split (manifest ``test.auto``) and fresh
#: rows through the served predictor (``validation_gate.served_figures``).
GATE_FIGURES = {"held_out": "held-out", "fresh": "fresh-row"}


def serve_decision(row: dict, accuracy) -> tuple[str, list[str]]:
    """The rule of the module docstring for one pair.

    Parameters
    ----------
    row : dict
        The pair's figures (:func:`measure_pair`), with those of :data:`GATE_FIGURES`
        (:func:`p99_figures`) where measured.
    accuracy : impactnet.models.scenes.Accuracy
        The scene's tolerance.

    Returns
    -------
    serve : str
        ``"learned"`` or ``"exact-only"``.
    reasons : list of str
        One line per goal the learned path misses (empty: learned).
    """
    reasons = []
    if min(row["speedup_n1"], row["speedup_batch"]) < SPEEDUP_REQUIRED:
        reasons.append(f"auto is {row['speedup_n1']:.2f}x the exact solver's speed at N = 1 "
                       f"and {row['speedup_batch']:.2f}x at N = {row['poses']:,} "
                       f"(< {SPEEDUP_REQUIRED:g}x required)")
    reasons += tolerance_misses("first-contact", row, accuracy)
    if row["missed"]:
        reasons.append(f"{row['missed']} missed contacts on the first-contact poses (> 0)")
    for key, where in GATE_FIGURES.items():
        if row.get(key) is not None:
            reasons += tolerance_misses(where, row[key], accuracy)
    differing = (row.get("fresh") or {}).get("flags_differing")
    if differing:
        reasons.append(f"{differing} contact flags differing from the exact solver's on the "
                       "fresh rows (> 0)")
    return ("exact-only" if reasons else "learned"), reasons


def tolerance_misses(where: str, figures: dict, accuracy) -> list[str]:
    """One line per p99 error of ``figures`` (``normal_p99_deg``, ``point_p99_fraction``) that
    misses the scene's ``accuracy`` or was not measured (no contact answered), e.g.
    ``"held-out auto p99 point 0.0206 > tolerance 0.02 (fraction of the shortest edge)"``."""
    misses = []
    for name, key, bound, unit in (("normal", "normal_p99_deg", accuracy.normal_deg, "deg"),
                                   ("point", "point_p99_fraction", accuracy.point_fraction,
                                    "fraction of the shortest edge")):
        value = figures.get(key)
        if value is None:
            misses.append(f"{where} auto p99 {name} not measured (no contact answered)")
        elif value > bound:
            misses.append(f"{where} auto p99 {name} {value:.4g} > tolerance {bound:g} ({unit})")
    return misses


def p99_figures(auto: dict) -> dict:
    """``auto``'s p99 errors from figures shaped like a manifest's ``test.auto`` (a pair's
    held-out test split, or ``validation_gate.served_figures``), keyed as in a decision row;
    ``flags_differing`` kept where given."""
    out = {"normal_p99_deg": auto["normal_deg"]["p99"],
           "point_p99_fraction": auto["point_fraction"]["p99"]}
    return out | ({"flags_differing": auto["flags_differing"]} if "flags_differing" in auto
                  else {})


def measure_pair(exact, auto, args: tuple, scale: np.ndarray, config: DecideConfig) -> dict:
    """Times and errors of one pair's poses (``args``: the six (n, .) solver arguments)."""
    reference = exact.batch(args)
    answer = auto.batch(args)
    exact_batch = median_repeated(lambda: exact.batch(args), config.repeats, warmup=False)
    auto_batch = median_repeated(lambda: auto.batch(args), config.repeats, warmup=False)
    picks = np.linspace(0, len(scale) - 1, config.single_calls + config.warmup).astype(int)
    singles = [tuple(a[i] for a in args) for i in picks]
    exact_one, _ = median_per_call(exact.one, singles, config.warmup)
    auto_one, _ = median_per_call(auto.one, singles, config.warmup)
    summary = method_summary(row_errors(answer, reference, scale))
    answered_by = answer.extra.get("answered_by", {})
    fallback = answered_by.get("exact", 0) / max(1, sum(answered_by.values()))
    n = len(scale)
    return {"poses": n, "exact_n1_us": exact_one * 1e6, "auto_n1_us": auto_one * 1e6,
            "exact_batch_us_per_pair": exact_batch / n * 1e6,
            "auto_batch_us_per_pair": auto_batch / n * 1e6,
            "speedup_n1": exact_one / auto_one, "speedup_batch": exact_batch / auto_batch,
            "fallback_share": fallback, "answered_by": answered_by,
            "contacts": summary.contacts, "missed": summary.missed,
            "normal_p99_deg": summary.normal_deg_p99,
            "point_p99_fraction": (None if summary.point_pct_p99 is None
                                   else summary.point_pct_p99 / 100.0)}


def learned_auto(bundle, scene_name: str):
    """(the ``auto`` method of the learned path, {pair: recorded ``serve``}, {pair: held-out
    figures (:func:`p99_figures`)}) of ``bundle``, by default the shipped
    ``models/bundles/<scene>`` (:func:`learned_bundle`)."""
    from impactnet.models.predictors import DEFAULT_BUNDLE, load_predictor

    learned, recorded = learned_bundle(bundle if bundle is not None else
                                       DEFAULT_BUNDLE.parent / scene_name)
    held_out = {key: p99_figures(block["test"]["auto"])
                for key, block in (learned.manifest.get("pairs") or {}).items()
                if "test" in block}
    return (predictor_method("auto", load_predictor("auto", learned), "learned"), recorded,
            held_out)


def decide(config: DecideConfig) -> dict:
    """The decision of every pair of ``config.scene`` with its figures, and the machine."""
    from impactnet.models.scenes import load_scene

    scene = load_scene(config.scene)
    scene.require_box_pairs("impactnet bench decide")
    exact = exact_method()
    auto, recorded, held_out = learned_auto(config.bundle, scene.name)
    poses = scene_poses(scene, config.poses_per_pair * len(scene.pairs), config.seed)
    pairs = []
    for k, pair in enumerate(scene.pairs):
        rows = np.flatnonzero(poses.pair == k)
        row = {"pair": pair.key} | measure_pair(exact, auto, poses.args(rows),
                                                poses.scale[rows], config)
        row["held_out"] = held_out.get(pair.key)
        row["decision"], row["reasons"] = serve_decision(row, scene.accuracy)
        row["recorded"] = recorded.get(pair.key)
        pairs.append(row)
    return {"scene": scene.name, "config": asdict(config), "machine": machine_info(),
            "rule": {"speedup_required": SPEEDUP_REQUIRED,
                     "normal_deg": scene.accuracy.normal_deg,
                     "point_fraction": scene.accuracy.point_fraction},
            "version": auto.info.get("version", ""), "pairs": pairs}


def report(result: dict) -> str:
    """The decisions as markdown."""
    rule = result["rule"]
    lines = [f"# Per-pair decision: scene `{result['scene']}`", "",
             "`impactnet bench decide`: the bundle's learned path (its recorded decisions "
             "lifted) against the exact solver, on the same first-contact poses of each pair.",
             "",
             f"A pair is learned only where `auto` (fallback rows included) is at least "
             f"{rule['speedup_required']:g}x faster than the exact solver at N = 1 and at "
             f"N = {result['config']['poses_per_pair']:,}, with p99 errors within "
             f"{rule['normal_deg']:g} deg and {rule['point_fraction']:.0%} of the shortest edge "
             f"on these poses and on the bundle's held-out test split, and no missed contact. "
             f"Bundle `{result['version']}`.", "",
             "| pair | exact N=1 µs | auto N=1 µs | speed-up N=1 | exact batch µs/pair | "
             "auto batch µs/pair | speed-up batch | auto fallback | normal p99 ° | "
             "point p99 | missed | decision | recorded |", "|---" * 13 + "|"]
    for p in result["pairs"]:
        normal = "-" if p["normal_p99_deg"] is None else f"{p['normal_p99_deg']:.3f}"
        point = "-" if p["point_p99_fraction"] is None else f"{p['point_p99_fraction']:.2%}"
        lines.append(
            f"| {p['pair']} | {p['exact_n1_us']:.1f} | {p['auto_n1_us']:.1f} | "
            f"{p['speedup_n1']:.2f}x | {p['exact_batch_us_per_pair']:.2f} | "
            f"{p['auto_batch_us_per_pair']:.2f} | {p['speedup_batch']:.2f}x | "
            f"{p['fallback_share']:.1%} | {normal} | {point} | {p['missed']} | "
            f"**{p['decision']}** | {p.get('recorded') or '-'} |")
    lines += ["", *(f"- `{p['pair']}` exact-only: {'; '.join(p['reasons'])}."
                    for p in result["pairs"] if p.get("reasons"))]
    return "\n".join(lines) + "\n"


def run(config: DecideConfig, out: str | None) -> dict:
    """:func:`decide`, printed, and written to ``out``/decide.{md,json} when given."""
    result = decide(config)
    text = report(result)
    print(text)
    if out:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "decide.md").write_text(text, encoding="utf-8")
        (folder / "decide.json").write_text(json.dumps(result, indent=1) + "\n",
                                            encoding="utf-8")
    return result
