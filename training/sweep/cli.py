"""`impactnet sweep`: argument parsing and the command body, for impactnet/cli.py to wire in.

    impactnet sweep --study NAME [--scene quay_crane] [--storage URL] [--trials 40]
                    [--pairs A/B ...] [--quick] [--out STORE] [--show]

Runs trials of the Optuna study NAME (:mod:`impactnet.training.sweep.run`) until it has ``--trials``
complete or pruned ones, then writes ``report.md`` and ``pareto.png``
(:mod:`impactnet.training.sweep.report`) and, with ``--out``, retrains the cheapest trial that meets
the scene's tolerance (on the trial's pairs) on all the scene's pairs and publishes it as a new
version of that bundle store (per-pair decisions and validation gate as in `impactnet train`: a pair
whose learned path is too slow or misses the tolerance is served exact-only; what serves each pair,
and why, is printed). Storage: SQLite under ``runs/sweeps/NAME/`` by default; any SQLAlchemy URL
(e.g. ``postgresql://user:pw@host/db``) shares the study between machines that run the same command.
Rerunning the command resumes the study by name. ``--show`` runs no trial: it prints the study's
state and the Pareto table (and publishes with ``--out``).

Exit status: 0 done; 2 bad arguments, scene or study; 3 no trial meets the tolerance or the
gate refused the pick (``current`` untouched); 130 interrupted.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

EXIT_OK = 0
EXIT_USAGE = 2
EXIT_NO_PICK = 3
EXIT_INTERRUPTED = 130
#: Where a study's files go by default: ``<RUNS_DIR>/<study>/`` (git-ignored ``runs/``).
RUNS_DIR = Path("runs") / "sweeps"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `sweep` options to ``parser``."""
    parser.add_argument("--study", required=True, help="study name (rerun to resume it)")
    parser.add_argument("--scene", default=None,
                        help="scene name or .toml path (default: quay_crane; --show: the "
                             "study's own)")
    parser.add_argument("--storage", default=None,
                        help="SQLAlchemy URL of the study storage (default: sqlite:///"
                             "runs/sweeps/<study>/study.sqlite3)")
    parser.add_argument("--workdir", default=None,
                        help="pair cache, trial files and report (default: runs/sweeps/<study>)")
    parser.add_argument("--trials", type=int, default=40,
                        help="complete + pruned trials of the study, over all workers "
                             "(default: 40)")
    parser.add_argument("--pairs", nargs="+", default=(), metavar="A/B",
                        help="pairs every trial trains (default: the scene's first pair)")
    parser.add_argument("--seed", type=int, default=0, help="data and torch seed (default: 0)")
    parser.add_argument("--quick", action="store_true",
                        help="quick base config and small search space: seconds per trial")
    parser.add_argument("--timing-rows", type=int, default=None,
                        help="poses the auto predictor is timed on (default: 100000; quick: "
                             "20000)")
    parser.add_argument("--heartbeat", type=int, default=30,
                        help="seconds between heartbeats of a running trial (default: 30)")
    parser.add_argument("--grace", type=int, default=90,
                        help="seconds without heartbeat before a trial counts as dead and is "
                             "retried (default: 90)")
    parser.add_argument("--max-retry", type=int, default=2,
                        help="retries of a dead worker's trial (default: 2)")
    parser.add_argument("--prune-startup", type=int, default=5,
                        help="complete trials before pruning starts (default: 5)")
    parser.add_argument("--sampler-seed", type=int, default=None,
                        help="TPE sampler seed (default: none, so workers differ)")
    parser.add_argument("--show", action="store_true",
                        help="run no trial: print the study's state and Pareto front")
    parser.add_argument("--out", default=None,
                        help="bundle store to publish the pick into (default: publish nothing)")
    parser.add_argument("--no-gate", action="store_true",
                        help="publish the pick even if it fails the validation gate")


def _config(args: argparse.Namespace):
    """The :class:`impactnet.training.sweep.run.SweepConfig` of the arguments (ValueError when
    bad)."""
    from impactnet.training.sweep.run import SweepConfig

    for name in ("trials", "heartbeat", "grace", "prune_startup"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name.replace('_', '-')} must be >= 1")
    if args.max_retry < 0 or args.seed < 0:
        raise ValueError("--max-retry and --seed must be >= 0")
    workdir = Path(args.workdir) if args.workdir else RUNS_DIR / args.study
    storage = args.storage
    if storage is None:
        workdir.mkdir(parents=True, exist_ok=True)
        storage = f"sqlite:///{(workdir / 'study.sqlite3').as_posix()}"
    timing = args.timing_rows or (20_000 if args.quick else 100_000)
    return SweepConfig(study=args.study, storage=storage, workdir=workdir, trials=args.trials,
                       pair_keys=tuple(args.pairs), seed=args.seed, quick=args.quick,
                       timing_rows=timing, heartbeat_s=args.heartbeat, grace_s=args.grace,
                       max_retry=args.max_retry, prune_startup=args.prune_startup,
                       sampler_seed=args.sampler_seed)


def run(args: argparse.Namespace) -> int:
    """Run (or show) the study named by ``args``; returns the exit status."""
    from impactnet.models.scenes import SceneError, load_scene
    from impactnet.training.sweep.run import SweepError, open_study, run_worker

    try:
        config = _config(args)
        if args.show:
            study = open_study(config)
            scene = load_scene(args.scene or study.user_attrs["scene_source"])
        else:
            scene = load_scene(args.scene or "quay_crane")
            _check_scene(scene, args)
            study = open_study(config, scene)
            if "scene_source" not in study.user_attrs:
                study.set_user_attr("scene_source", str(args.scene or "quay_crane"))
            run_worker(config, scene)
    except KeyboardInterrupt:
        print(f"impactnet sweep: interrupted; the study {args.study!r} keeps its finished "
              "trials: run the same command to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (SceneError, SweepError, ValueError, KeyError) as exc:
        print(f"impactnet sweep: {exc}", file=sys.stderr)
        return EXIT_USAGE
    return _report_and_publish(args, config, study, scene)


def _check_scene(scene, args) -> None:
    """A scene of box pairs, or of compound pairs only (ValueError otherwise); a compound
    study's pick is not published (retrain it with `impactnet train`)."""
    from impactnet.training.data.compound_dataset import is_compound_scene

    compound = is_compound_scene(scene)
    if not compound:
        scene.require_box_pairs("impactnet sweep")  # a mixed scene: refused, naming a pair
    if compound and args.out:
        raise ValueError("--out publishes box bundles only; train a compound scene's pick "
                         "with `impactnet train` and the trial's settings")


def _report_and_publish(args, config, study, scene) -> int:
    """Print the state and the Pareto table, write the report, publish the pick if asked."""
    from impactnet.training.jobs.decisions import decision_lines
    from impactnet.training.jobs.retrain import JobConfig
    from impactnet.training.sweep.report import (
        pareto_table,
        publish_pick,
        study_summary,
        trial_rows,
        write_report,
    )

    print(study_summary(study, config.storage))
    report, picked = write_report(study, scene, config.workdir)
    rows = trial_rows(study, scene)
    if rows:
        print(pareto_table(rows, picked))
    print(f"report: {report}")
    if picked is None:
        print("impactnet sweep: no complete trial meets the scene's tolerance yet",
              file=sys.stderr)
        return EXIT_NO_PICK if args.out else EXIT_OK
    print(f"pick: trial {picked['number']} ({picked['auto_us']:.3g} us/pair): "
          f"{picked['params']}")
    if not args.out:
        return EXIT_OK
    rebuild = (f"impactnet sweep --study {study.study_name} --storage <URL> --show "
               f"--out {Path(args.out).as_posix()}")
    outcome = publish_pick(study, scene, picked, args.out,
                           JobConfig(enforce_gate=not args.no_gate), progress=False,
                           workdir=config.workdir, rebuild=rebuild)
    print("served per pair:\n  " + "\n  ".join(decision_lines(outcome.manifest)))
    if not outcome.published:
        print("impactnet sweep: the pick failed the validation gate:\n  "
              + "\n  ".join(outcome.gate.failures), file=sys.stderr)
        return EXIT_NO_PICK
    print(f"wrote {outcome.path}; {args.out}/current -> {outcome.version}")
    return EXIT_OK
