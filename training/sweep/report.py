"""A sweep's results: the Pareto front as a Markdown table and a PNG plot, and the pick.

:func:`trial_rows` reads the complete trials of a study (objectives and recorded figures);
:func:`pick` chooses the cheapest trial (lowest measured ``auto`` microseconds per pair) whose
``auto`` test errors meet the scene's tolerance (p99 normal <= ``accuracy.normal_deg``, p99
point <= ``accuracy.point_fraction``: the validation gate's criterion), ties broken by the
committee's errors; such a trial is always on the Pareto front or tied with one.
:func:`publish_pick` retrains the pick's settings on every pair of the scene (trial pairs come
from the sweep's pair cache) into a new version of a bundle store, through the same gate as
``impactnet train`` (:func:`impactnet.training.jobs.retrain.run_train_job`).
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from impactnet.models.scenes import Scene
from impactnet.training.sweep.run import OBJECTIVES, public_url, state_counts
from impactnet.training.sweep.space import SweepSpace, config_from_params

#: Columns of the Markdown table: (header, row key, format).
_COLUMNS = (("trial", "number", "{}"), ("auto fallback", "fallback", "{:.1%}"),
            ("committee point p99 (of edge)", "point_p99", "{:.3g}"),
            ("auto us/pair", "auto_us", "{:.3g}"), ("committee us/pair", "committee_us",
                                                    "{:.3g}"),
            ("committee normal p99 (deg)", "normal_p99", "{:.3g}"),
            ("auto p99 normal / point", "auto_p99", "{}"), ("meets tolerance", "meets", "{}"),
            ("params", "params_text", "{}"))


def trial_rows(study, scene: Scene) -> list[dict]:
    """One dict per complete trial: number, params, objectives, figures, ``front`` (on the
    Pareto front) and ``meets`` (auto meets the scene's tolerance)."""
    from optuna.trial import TrialState

    front = {t.number for t in study.best_trials}
    rows = []
    for trial in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)):
        attrs = trial.user_attrs
        normal, point = attrs.get("auto_normal_p99"), attrs.get("auto_point_p99")
        meets = attrs.get("meets")  # compound trials record it (their point is in tolerances)
        if meets is None:
            meets = (normal is not None and point is not None
                     and normal <= scene.accuracy.normal_deg
                     and point <= scene.accuracy.point_fraction)
        rows.append({"number": trial.number, "params": dict(trial.params),
                     "params_text": _params_text(trial.params),
                     **dict(zip(OBJECTIVES, trial.values)), **attrs,
                     "auto_p99": f"{_fmt(normal)} / {_fmt(point)}",
                     "front": trial.number in front, "meets": bool(meets)})
    return rows


def _params_text(params: dict) -> str:
    """``name=value`` pairs, floats to 3 significant digits."""
    return ", ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}"
                     for k, v in params.items())


def _fmt(value) -> str:
    return "-" if value is None else f"{value:.3g}"


def pick(rows: list[dict]) -> dict | None:
    """The cheapest row that meets the tolerance (module docstring); None if there is none."""
    eligible = [r for r in rows if r["meets"]]
    if not eligible:
        return None
    return min(eligible, key=lambda r: (r["auto_us"], r["fallback"], r["point_p99"],
                                        r["number"]))


def pareto_table(rows: list[dict], picked: dict | None) -> str:
    """The Pareto front as a Markdown table, cheapest first; the pick is marked."""
    front = sorted((r for r in rows if r["front"]), key=lambda r: r["auto_us"])
    lines = ["| " + " | ".join(h for h, _, _ in _COLUMNS) + " |",
             "|" + "|".join("---:" if k != "params_text" else "---" for _, k, _ in _COLUMNS) + "|"]
    for row in front:
        cells = ["-" if row.get(key) is None else fmt.format(row.get(key))
                 for _, key, fmt in _COLUMNS]  # a compound trial has no committee_us
        if picked is not None and row["number"] == picked["number"]:
            cells[0] = f"**{cells[0]} (pick)**"
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot_front(rows: list[dict], path: Path, scene: Scene, picked: dict | None) -> Path:
    """Cost against both errors, every complete trial, the front and the pick marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, key, label in ((axes[0], "fallback", "auto fallback share"),
                           (axes[1], "point_p99", "committee point p99 (fraction of edge)")):
        for subset, style in (([r for r in rows if not r["front"]], dict(c="0.7", s=14)),
                              ([r for r in rows if r["front"]], dict(c="C0", s=28))):
            ax.scatter([r["auto_us"] for r in subset], [r[key] for r in subset], **style)
        if picked is not None:
            ax.scatter([picked["auto_us"]], [picked[key]], marker="*", s=200, c="C3",
                       label=f"pick: trial {picked['number']}")
            ax.legend(loc="best")
        ax.set_xlabel("auto: measured us per pair")
        ax.set_ylabel(label)
        values = [r[key] for r in rows]
        if min(values) > 0 and max(values) > 10 * min(values):  # log only where it spreads
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{scene.name}: {len(rows)} complete trials, Pareto front in blue")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_report(study, scene: Scene, folder) -> tuple[Path, dict | None]:
    """``report.md`` (status, Pareto table, pick) and ``pareto.png`` in ``folder``."""
    folder = Path(folder)
    rows = trial_rows(study, scene)
    picked = pick(rows)
    counts = {k: v for k, v in state_counts(study).items() if v}
    text = [f"# Sweep {study.study_name}: {scene.name}", "",
            f"Trials by state: {counts}. Objectives (minimised): {', '.join(OBJECTIVES)}; "
            f"tolerance: auto p99 normal <= {scene.accuracy.normal_deg} deg, p99 point <= "
            f"{scene.accuracy.point_fraction} of the shortest edge.", "",
            pareto_table(rows, picked) if rows else "No complete trial yet.", ""]
    if rows:
        plot_front(rows, folder / "pareto.png", scene, picked)
        text += ["![Pareto front](pareto.png)", ""]
    text.append(f"Pick: trial {picked['number']}, {picked['params']}" if picked
                else "Pick: none (no complete trial meets the tolerance).")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "report.md").write_text("\n".join(text) + "\n", encoding="utf-8")
    return folder / "report.md", picked


def publish_pick(study, scene: Scene, picked: dict, out, job=None, progress=None,
                 workdir=None, rebuild: str = ""):
    """Retrain ``picked`` on every pair of ``scene`` into the store ``out`` (gated).

    Returns the :class:`impactnet.training.jobs.retrain.JobOutcome`.
    """
    from impactnet.training.jobs.retrain import JobConfig, run_train_job
    from impactnet.training.sweep.run import SweepConfig

    attrs = study.user_attrs
    if attrs.get("scene_hash") != scene.hash():
        raise ValueError(f"study {study.study_name!r} was run on another version of scene "
                         f"{scene.name!r} (hash differs)")
    space = SweepSpace(**{k: tuple(v) for k, v in attrs["space"].items()})
    base = SweepConfig(study.study_name, "", Path("."), seed=attrs["seed"],
                       quick=attrs["quick"]).base()
    config = dataclasses.replace(base, pair=config_from_params(picked["params"], space,
                                                               base.pair))
    job = job or JobConfig()
    if workdir is not None and job.cache_dir is None:  # the trials' pairs are reused
        job = dataclasses.replace(job, cache_dir=Path(workdir) / "cache")
    annotate = {"sweep": {"study": study.study_name, "trial": picked["number"],
                          "params": picked["params"],
                          "objectives": {k: picked[k] for k in OBJECTIVES}}}
    if rebuild:
        annotate["rebuild_command"] = rebuild
    return run_train_job(scene, out, config, job, progress, annotate)


def study_summary(study, storage: str) -> str:
    """The study's identity, storage and trial counts, one JSON line."""
    attrs = {k: v for k, v in study.user_attrs.items() if k != "space"}
    counts = {k: v for k, v in state_counts(study).items() if v}
    return json.dumps({"study": study.study_name, "storage": public_url(storage), **attrs,
                       "trials": counts}, sort_keys=True)
