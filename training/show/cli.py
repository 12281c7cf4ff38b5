"""`impactnet show`: argument parsing and the command body, for impactnet/cli.py to wire in.

    impactnet show --scene quay_crane_detail --pair container40/container40 [--seed 0]
                   [--depth-mm 1] [--out show/]
    impactnet show --scene quay_crane_detail --labels spreader [--out docs/images]

The first form writes ``<out>/<a>_<b>_seed<seed>.png`` and ``.glb`` and prints a one-line
summary; the second draws a body's parts with their names (``<out>/parts_<body>.png``,
:mod:`impactnet.training.show.labels`).
"""
from __future__ import annotations

import argparse
import sys

EXIT_OK, EXIT_USAGE = 0, 2


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `show` options to ``parser``."""
    parser.add_argument("--scene", default="quay_crane_detail", help="scene name or .toml path "
                        "(default: quay_crane_detail)")
    parser.add_argument("--pair", help="the pair as A/B body names, e.g. "
                        "container40/container40")
    parser.add_argument("--labels", metavar="BODY", help="draw this body's parts with their "
                        "names instead of a pose")
    parser.add_argument("--seed", type=int, default=0, help="pose seed (default: 0)")
    parser.add_argument("--depth-mm", type=float, default=1.0,
                        help="push past the first contact, millimetres (default: 1)")
    parser.add_argument("--out", default="show", help="output folder (default: show/)")


def _labels(args: argparse.Namespace) -> int:
    from pathlib import Path

    from impactnet.models.scenes import SceneError, load_scene
    from impactnet.training.show.labels import write_labels
    from impactnet.training.show.pose import body_parts

    try:
        scene = load_scene(args.scene)
        parts = body_parts(scene, args.labels)
    except (SceneError, ValueError) as exc:
        print(f"impactnet show: {exc}", file=sys.stderr)
        return EXIT_USAGE
    spec = scene.body(args.labels).spec or {}
    detail = ", ".join(f"{k} {v}" for k, v in spec.items() if k != "parts") or "parts"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"parts_{args.labels}.png"
    groups = write_labels(path, args.labels, parts, detail)
    print(f"wrote {path} ({groups} part groups of {args.labels} in scene {scene.name})")
    return EXIT_OK


def run(args: argparse.Namespace) -> int:
    """Draw the pose (or a body's labelled parts); returns the exit status."""
    from pathlib import Path

    if args.labels:
        return _labels(args)
    if not args.pair:
        print("impactnet show: give --pair A/B or --labels BODY", file=sys.stderr)
        return EXIT_USAGE

    import numpy as np

    from impactnet.models.compound import compound_answer
    from impactnet.models.geometry.rotations import quaternion_to_matrix
    from impactnet.models.scenes import SceneError, load_scene
    from impactnet.training.show.pose import body_parts, contact_pose
    from impactnet.training.show.render import write_glb, write_png

    try:
        scene = load_scene(args.scene)
        name_a, name_b = args.pair.split("/") if args.pair.count("/") == 1 else ("", "")
        parts_a, parts_b = body_parts(scene, name_a), body_parts(scene, name_b)
    except (SceneError, ValueError) as exc:
        print(f"impactnet show: {exc} (--pair A/B with the scene's body names)", file=sys.stderr)
        return EXIT_USAGE
    pose = contact_pose(parts_a, parts_b, args.seed, 1e-3 * args.depth_mm)
    if pose is None:
        print(f"impactnet show: no touching pose for seed {args.seed}", file=sys.stderr)
        return EXIT_USAGE
    position, quaternion = pose
    answer = compound_answer(parts_a, np.zeros(3), [1.0, 0, 0, 0], parts_b, position,
                             quaternion)
    rotation_b = quaternion_to_matrix(np.asarray(quaternion)[None])[0]
    bodies = [(parts_a, np.zeros(3), np.eye(3), set(answer.parts.part_a.tolist())),
              (parts_b, position, rotation_b, set(answer.parts.part_b.tolist()))]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"{name_a}_{name_b}_seed{args.seed}"
    title = (f"{scene.name}: {args.pair}, seed {args.seed}: {len(answer.parts.pose)} part "
             f"contacts, deepest {1e3 * answer.summary.depth[0]:.3f} mm")
    write_png(stem.with_suffix(".png"), answer, bodies, title)
    meshes = write_glb(stem.with_suffix(".glb"), answer, bodies)
    print(title)
    print(f"wrote {stem}.png and {stem}.glb ({meshes} meshes)")
    return EXIT_OK
