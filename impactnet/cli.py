"""The `impactnet` command line.

    impactnet serve | datagen | train | sweep | evaluate | bench | reproduce-paper | contact

This is the one module that may reach both `training` (torch) and `service` (fastapi), and it
does so only lazily, inside the subcommand that needs them: `impactnet contact` must run in a
runtime-only install, and `--help` must be instant. Nothing heavy (not even numpy) is imported at
module level.

Every subcommand is delegated to the module named in `_DELEGATED`; `contact` answers one pair
as the HTTP API does.
"""
from __future__ import annotations

import argparse
from collections.abc import Sequence

# ----------------------------------------------------------------------------- delegated

# Subcommands whose arguments and work live in another module, as `add_arguments(parser)` and
# `run(args) -> int`. Those modules import nothing heavy at module level (checked by the CLI
# tests), so building the parser stays instant; the work itself imports lazily.
_DELEGATED = {
    "serve": ("impactnet.service.cli", "serve the HTTP/JSON contact service (default: the "
                                       "quay_crane scene on 127.0.0.1:8000)"),
    "datagen": ("impactnet.training.data.cli",
                "generate labelled first-contact datasets for the pairs of a scene"),
    "bench": ("impactnet.training.bench.cli",
              "speed and accuracy of every method on the same poses ('bench exact': the exact "
              "solver against python-fcl)"),
    "train": ("impactnet.training.jobs.cli",
              "train the learned predictors of a scene's pairs into a bundle"),
    "evaluate": ("impactnet.training.evaluate.cli",
                 "measure every predictor of a bundle on a held-out test set against the goals "
                 "of issue 4 (Markdown report, JSON, PNG plots)"),
    "sweep": ("impactnet.training.sweep.cli",
              "multi-objective hyper-parameter sweep with Optuna (error against measured cost; "
              "SQLite or PostgreSQL storage, resumable by name)"),
    "reproduce-paper": ("impactnet.training.paper.cli",
                        "reproduce the paper's Tables 1 and 2 and Figures 5 and 6"),
    "contact": ("impactnet.service.contact_cli",
                "one pair answered as POST /v2/contact answers it (exact), printed as JSON"),
    "show": ("impactnet.training.show.cli",
             "draw one contact pose of a scene's pair with its part contacts (PNG and GLB)"),
}


def _add_delegated(sub) -> None:
    import importlib

    for name, (module_name, help_text) in _DELEGATED.items():
        module = importlib.import_module(module_name)
        p = sub.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(p)
        p.set_defaults(handler=module.run)


# ----------------------------------------------------------------------------- parser


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="impactnet",
        description="Box-box contact (impact point, force direction, depth, contact type) for "
                    "real-time simulation.",
    )
    from impactnet import __version__

    parser.add_argument("--version", action="version", version=f"impactnet {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    _add_delegated(sub)

    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.handler(args)


if __name__ == "__main__":
    raise SystemExit(main())
