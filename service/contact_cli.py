"""``impactnet contact``: one pair answered as POST /v2/contact answers it, from the command line.

The flags build the API's request (:class:`~impactnet.service.codecs.requests.ContactRequest`),
which is validated, decoded and solved by the same code as the HTTP route (exact mode, the
scene's bodies), and the answer printed as JSON. Bad input prints the HTTP answer's one-line
message and exits with status 2, never a traceback::

    impactnet contact --object-a container40 --position-a 0 0 1.2955 \\
        --object-b spreader --position-b 0 0 3.0 --euler-b 0 0 0.01 --scene quay_crane_detail
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

#: The default pair: the paper's cubes (edge 2 m); B rests on A's top face, offset sideways,
#: 5 cm pushed in and tilted by 0.05 rad about the horizontal axis (1, 1, 0), so that one
#: vertex of B dips into A's top face.
CUBE = [2.0, 2.0, 2.0]
TILT_RAD = 0.05
DEFAULT_POSITION_B = [0.5, 0.3, 1.95]
DEFAULT_QUATERNION_B = [math.cos(TILT_RAD / 2), math.sin(TILT_RAD / 2) / math.sqrt(2.0),
                        math.sin(TILT_RAD / 2) / math.sqrt(2.0), 0.0]
#: Exit status of a refused request (argparse's own for bad usage).
EXIT_REFUSED = 2
_NUMBER_LIST = re.compile(r"\[\s*([-+0-9.eE,\s]+?)\s*\]")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``impactnet contact`` (module docstring)."""
    for side in "ab":
        group = parser.add_argument_group(f"body {side.upper()}")
        shape = group.add_mutually_exclusive_group()
        shape.add_argument(f"--object-{side}", metavar="NAME", help="a body of the scene")
        shape.add_argument(f"--size-{side}", nargs=3, type=float, metavar=("LX", "LY", "LZ"),
                           help="a box: full edge lengths, m (default: the paper's cube)")
        shape.add_argument(f"--parts-{side}", type=Path, metavar="FILE",
                           help="a JSON file of inline parts (the scene files' part format)")
        group.add_argument(f"--position-{side}", nargs=3, type=float, metavar=("X", "Y", "Z"),
                           help="centre, m")
        turn = group.add_mutually_exclusive_group()
        turn.add_argument(f"--quaternion-{side}", nargs=4, type=float,
                          metavar=("W", "X", "Y", "Z"))
        turn.add_argument(f"--euler-{side}", nargs=3, type=float, metavar=("R", "P", "Y"),
                          help="radians, --euler-convention")
        turn.add_argument(f"--matrix-{side}", nargs=9, type=float, metavar="R",
                          help="3x3 rotation, row by row")
    parser.add_argument("--scene", default="quay_crane",
                        help="the scene whose bodies --object names (default: %(default)s)")
    parser.add_argument("--margin", type=float, default=0.0,
                        help="m: a pair apart by less answers its gap and closest points")
    parser.add_argument("--include", action="append", default=[],
                        choices=("manifold", "paper_angles"), help="optional outputs")
    parser.add_argument("--euler-convention", default="zyx", choices=("zyx", "xyz"))


def _body(args: argparse.Namespace, side: str) -> dict:
    """One body of the request from the flags (the default pair where none is given)."""
    given = {name: getattr(args, f"{name}_{side}") for name in
             ("object", "size", "parts", "position", "quaternion", "euler", "matrix")}
    body = {k: v for k, v in given.items() if v is not None}
    if not {"object", "size", "parts"} & set(body):
        body["size"] = CUBE
    if "parts" in body:
        body["parts"] = json.loads(Path(body["parts"]).read_text())
    if "matrix" in body:
        body["matrix"] = [body["matrix"][0:3], body["matrix"][3:6], body["matrix"][6:9]]
    body.setdefault("position", [0.0, 0.0, 0.0] if side == "a" else DEFAULT_POSITION_B)
    if not {"quaternion", "euler", "matrix"} & set(body):
        body["quaternion"] = [1.0, 0.0, 0.0, 0.0] if side == "a" else DEFAULT_QUATERNION_B
    return body


def answer(request_json: dict, scene_name: str | None) -> dict:
    """The answer of one pair's request (POST /v2/contact's JSON, exact mode)."""
    from impactnet.models.dispatch import Dispatcher
    from impactnet.service.codecs.answers import row_json
    from impactnet.service.codecs.json_keys import validated_unique
    from impactnet.service.codecs.pair import part_limits, request_pairs
    from impactnet.service.codecs.requests import ContactRequest
    from impactnet.service.scene import load_scene_view
    from impactnet.service.settings import Settings
    from impactnet.service.solve import solve_now

    request = validated_unique(ContactRequest, json.dumps(request_json).encode(),
                               "application/json")
    settings = Settings(scene=scene_name)
    pairs, notes = request_pairs(request, load_scene_view(scene_name), part_limits(settings))
    answers = solve_now(Dispatcher(), pairs, "exact", request.include, request.margin,
                        settings)
    out = row_json(answers, pairs, request.include)
    return out | ({"warnings": notes} if notes else {}) | {"mode": "exact"}


def dumps_compact(body: dict) -> str:
    """JSON indented by 2, with lists of numbers kept on one line."""
    text = json.dumps(body, indent=2)
    return _NUMBER_LIST.sub(
        lambda m: "[" + ", ".join(part.strip() for part in m.group(1).split(",")) + "]", text)


def run(args: argparse.Namespace) -> int:
    """Print the answer; a refused request prints the API's message and returns 2."""
    from impactnet.service.errors import ServiceError
    from impactnet.service.scene import SceneLoadError

    request = {"a": _body(args, "a"), "b": _body(args, "b"), "margin": args.margin,
               "include": args.include, "euler_convention": args.euler_convention}
    try:
        body = answer(request, args.scene)
    except ServiceError as exc:
        print(f"impactnet contact: {exc.status_code} {exc.error}: {exc.message}",
              file=sys.stderr)
        return EXIT_REFUSED
    except (SceneLoadError, OSError, ValueError) as exc:  # a scene or a parts file
        print(f"impactnet contact: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    print(dumps_compact(body))
    return 0
