"""CLI glue of `impactnet reproduce-paper [--quick] [--out reports/paper] [--seed 0]`.

``impactnet/cli.py`` calls :func:`add_arguments` on its subparser and :func:`run` with the parsed
arguments. Without that wiring: ``python -m impactnet.training.paper.cli [--quick] ...``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

DEFAULT_OUT = "reports/paper"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `impactnet reproduce-paper`."""
    parser.add_argument("--quick", action="store_true",
                        help="small sets and few epochs (under a minute); same files")
    parser.add_argument("--out", default=DEFAULT_OUT,
                        help=f"report folder (default {DEFAULT_OUT})")
    parser.add_argument("--seed", type=int, default=0, help="seed of data and training")


def run(args: argparse.Namespace) -> int:
    """Reproduce the paper's tables and figures into ``args.out``; 0 on success."""
    from impactnet.training.paper import report as paper_report
    from impactnet.training.paper.reproduce import ReproduceConfig, quick_config, reproduce

    config = quick_config(args.seed) if args.quick else ReproduceConfig(seed=args.seed)
    results = reproduce(config)
    out = Path(args.out)
    paper_report.write(results, out, str(args.out))
    print(f"reproduce-paper: wrote {out / 'report.md'}, {out / 'tables.json'} and 2 figures "
          f"in {results['total_seconds']:.0f} s", file=sys.stderr)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="impactnet reproduce-paper", description=__doc__)
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
