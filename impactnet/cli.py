"""The `impactnet` command line.

    impactnet serve | datagen | train | sweep | evaluate | bench | reproduce-paper | contact

This is the one module that may reach both `training` (torch) and `service` (fastapi), and it
does so only lazily, inside the subcommand that needs them: `impactnet contact` must run in a
runtime-only install, and `--help` must be instant. Nothing heavy (not even numpy) is imported at
module level.

`serve`, `datagen`, `train`, `sweep`, `evaluate`, `bench` and `reproduce-paper` are delegated
to the modules named in `_DELEGATED`; `contact` prints one exact box-box contact as JSON.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
from collections.abc import Sequence

# Default pair of `impactnet contact`: the paper's cubes (edge 2 m); B rests on A's top face,
# offset sideways, 5 cm pushed in and tilted by 0.05 rad about the horizontal axis (1, 1, 0), so
# one vertex of B dips into A's top face.
_CUBE = [2.0, 2.0, 2.0]
_TILT_RAD = 0.05
_DEFAULT_QUATERNION_B = [
    math.cos(_TILT_RAD / 2),
    math.sin(_TILT_RAD / 2) / math.sqrt(2.0),
    math.sin(_TILT_RAD / 2) / math.sqrt(2.0),
    0.0,
]


# ----------------------------------------------------------------------------- contact


def _cmd_contact(args: argparse.Namespace) -> int:
    try:
        from impactnet.models.box.exact import box_box
    except ImportError as exc:
        print(f"impactnet contact: the exact solver is not available ({exc}).", file=sys.stderr)
        return 1
    contacts = box_box(
        args.size_a, args.position_a, args.quaternion_a,
        args.size_b, args.position_b, args.quaternion_b,
    )
    body = {
        "input": {
            "a": {"size": args.size_a, "position": args.position_a,
                  "quaternion": args.quaternion_a},
            "b": {"size": args.size_b, "position": args.position_b,
                  "quaternion": args.quaternion_b},
        },
        **contact_row_to_json(contacts, 0),
    }
    print(dumps_compact(body))
    return 0


_NUMBER_LIST = re.compile(r"\[\s*([-+0-9.eE,\s]+?)\s*\]")


def dumps_compact(body: dict) -> str:
    """JSON indented by 2, with lists of numbers kept on one line."""
    text = json.dumps(body, indent=2)
    return _NUMBER_LIST.sub(
        lambda m: "[" + ", ".join(part.strip() for part in m.group(1).split(",")) + "]", text
    )


def contact_row_to_json(contacts, i: int) -> dict:
    """Row i of a `impactnet.models.contacts.Contacts` as plain JSON types (valid manifold rows
    only)."""
    count = int(contacts.manifold_count[i])
    out = {
        "predictor": str(contacts.predictor[i]) if contacts.predictor is not None else "exact",
        "colliding": bool(contacts.colliding[i]),
        "contact_type": str(contacts.contact_type[i]),
        "normal": [float(v) for v in contacts.normal[i]],
        "depth": float(contacts.depth[i]),
        "point": [float(v) for v in contacts.point[i]],
        "feature_a": int(contacts.feature_a[i]),
        "feature_b": int(contacts.feature_b[i]),
        "axis": int(contacts.axis[i]),
        "manifold": {
            "count": count,
            "points": [[float(v) for v in p] for p in contacts.manifold_points[i, :count]],
            "depths": [float(v) for v in contacts.manifold_depths[i, :count]],
        },
    }
    try:  # readable feature names, where the feature module provides them
        from impactnet.models.geometry.box_features import feature_name

        out["feature_a_name"] = str(feature_name(int(contacts.feature_a[i])))
        out["feature_b_name"] = str(feature_name(int(contacts.feature_b[i])))
    except Exception:  # noqa: BLE001 - names are a convenience, ids are the answer
        pass
    return out


# ----------------------------------------------------------------------------- delegated

# Subcommands whose arguments and work live in another module, as `add_arguments(parser)` and
# `run(args) -> int`. Those modules import nothing heavy at module level (checked by the CLI
# tests), so building the parser stays instant; the work itself imports lazily.
_DELEGATED = {
    "serve": ("impactnet.service.cli", "serve the HTTP/JSON contact service (default: the "
                                       "quay_crane "
                             "scene on 127.0.0.1:8000)"),
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

    contact = sub.add_parser(
        "contact",
        help="one exact box-box contact, printed as JSON",
        description="Contact of two boxes by the exact solver "
                    "(impactnet.models.box.exact.box_box), as JSON. "
                    "Units: metres; size = full edge lengths; quaternion = [w, x, y, z] "
                    "(normalised on input); the normal points from A towards B. Defaults: two "
                    "cubes of edge 2, B on A's top face, 5 cm deep, tilted by 0.05 rad.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    contact.add_argument("--size-a", nargs=3, type=float, default=_CUBE, metavar=("LX", "LY", "LZ"))
    contact.add_argument("--position-a", nargs=3, type=float, default=[0.0, 0.0, 0.0],
                         metavar=("X", "Y", "Z"))
    contact.add_argument("--quaternion-a", nargs=4, type=float, default=[1.0, 0.0, 0.0, 0.0],
                         metavar=("W", "X", "Y", "Z"))
    contact.add_argument("--size-b", nargs=3, type=float, default=_CUBE, metavar=("LX", "LY", "LZ"))
    contact.add_argument("--position-b", nargs=3, type=float, default=[0.5, 0.3, 1.95],
                         metavar=("X", "Y", "Z"))
    contact.add_argument("--quaternion-b", nargs=4, type=float, default=_DEFAULT_QUATERNION_B,
                         metavar=("W", "X", "Y", "Z"))
    contact.set_defaults(handler=_cmd_contact)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.handler(args)


if __name__ == "__main__":
    raise SystemExit(main())
