"""A container yard for frames, tests and benchmarks: stacks one to six high on a grid, cell
guides at the corners of some stacks, and a spreader coming down over a stack.

The yard and the guides are the static world (registered once); the spreader, and the
container it carries when asked, move. Stacked containers rest on each other a little deep
(``stack_depth``), as a simulator's contact step leaves them, with a small seeded jitter of
their place and heading, so that the world is neither aligned nor regular.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.dispatch.shapes import Shape
from impactnet.models.frame.bodies import Bodies


@dataclass(frozen=True)
class YardLayout:
    """How a yard is laid out (metres, radians)."""

    rows: int = 4  # stacks across
    cols: int = 5  # stacks along
    max_height: int = 6  # containers in the highest stack (each stack 1 to max_height)
    gap_x: float = 0.6  # between the ends of two neighbouring stacks
    gap_y: float = 0.4  # between the sides of two neighbouring stacks
    stack_depth: float = 0.002  # a container's overlap with the one beneath it
    jitter: float = 0.01  # a container's place varies this much along x and y
    jitter_yaw: float = 0.002  # its heading this much
    guided_stacks: int = 2  # stacks with a cell guide at each of their four corners
    guide_clearance: float = 0.02  # between a guide's inner faces and the container's sides
    spreader_gap: float = 0.05  # from the spreader's lowest point down to the stack it is over


@dataclass(frozen=True)
class Yard:
    """A yard: its static ``world`` and the ``moving`` bodies."""

    world: Bodies
    moving: Bodies

    def frame(self, static_world: bool = True) -> Bodies:
        """The world and the moving bodies as one frame's bodies; ``static_world`` False
        frees the world's bodies too (every body on a free joint: the stacks' own contacts
        are then answered as well)."""
        bodies = self.world.joined(self.moving)
        if static_world:
            return bodies
        return Bodies(bodies.ids, bodies.shapes, bodies.shape, bodies.position,
                      bodies.quaternion, bodies.contype, bodies.conaffinity)


def _yaw_quaternions(yaw: np.ndarray) -> np.ndarray:
    half = 0.5 * np.asarray(yaw, np.float64)
    return np.stack([np.cos(half), np.zeros_like(half), np.zeros_like(half), np.sin(half)], 1)


def _stacks(container: Shape, layout: YardLayout, rng) -> tuple[np.ndarray, np.ndarray, list]:
    """Container positions (n, 3), yaws (n,), and per stack its top (x, y, z_top)."""
    length, width, height = container.size if container.is_box else 2 * container.bounds[1]
    positions, yaws, tops = [], [], []
    for r in range(layout.rows):
        for c in range(layout.cols):
            x, y = c * (length + layout.gap_x), r * (width + layout.gap_y)
            levels = int(rng.integers(1, layout.max_height + 1))
            z = 0.5 * height
            for _ in range(levels):
                dx, dy = rng.uniform(-layout.jitter, layout.jitter, 2)
                positions.append((x + dx, y + dy, z))
                yaws.append(rng.uniform(-layout.jitter_yaw, layout.jitter_yaw))
                z += height - layout.stack_depth
            tops.append((x, y, z - 0.5 * height + layout.stack_depth))
    return np.array(positions), np.array(yaws), tops


def _guides(guide: Shape, container: Shape, tops: list, layout: YardLayout):
    """Cell guide positions (g, 3) and yaws (g,): the four corners of the first stacks, each
    turned so that its cell holds the container's corner."""
    length, width, _ = container.size if container.is_box else 2 * container.bounds[1]
    centre, half = guide.bounds
    ground = half[2] - centre[2]  # lifts the guide's lowest point to z = 0
    inset = layout.guide_clearance + 0.014  # clearance and the angle's thickness
    positions, yaws = [], []
    for x, y, _ in tops[:layout.guided_stacks]:
        corners = ((-1, -1, 0.0), (1, -1, 0.5 * np.pi), (1, 1, np.pi), (-1, 1, 1.5 * np.pi))
        for sx, sy, yaw in corners:
            positions.append((x + sx * (0.5 * length + inset), y + sy * (0.5 * width + inset),
                              ground))
            yaws.append(yaw)
    return np.array(positions).reshape(-1, 3), np.array(yaws)


def yard(shapes: dict[str, Shape], layout: YardLayout = YardLayout(), seed: int = 0,
         container: str = "container40", spreader: str = "spreader",
         guide: str | None = "cell_guide") -> Yard:
    """A seeded yard of the named shapes (module docstring).

    ``shapes``: name -> :class:`~impactnet.models.dispatch.Shape`
    (:func:`~impactnet.models.dispatch.shapes.scene_shapes` of a scene). The spreader hangs
    ``layout.spreader_gap`` above the last stack's top, lined up with it.
    """
    rng = np.random.default_rng(seed)
    box, lifter = shapes[container], shapes[spreader]
    positions, yaws, tops = _stacks(box, layout, rng)
    ids = [f"c{k}" for k in range(len(positions))]
    kinds = [0] * len(positions)
    world_shapes: tuple[Shape, ...] = (box,)
    if guide is not None and layout.guided_stacks:
        g_positions, g_yaws = _guides(shapes[guide], box, tops, layout)
        positions, yaws = np.concatenate([positions, g_positions]), np.concatenate([yaws, g_yaws])
        ids += [f"g{k}" for k in range(len(g_positions))]
        kinds += [1] * len(g_positions)
        world_shapes += (shapes[guide],)
    world = Bodies(tuple(ids), world_shapes, np.array(kinds, np.int64), positions,
                   _yaw_quaternions(yaws))
    x, y, z_top = tops[-1]
    centre, half = lifter.bounds
    lift = z_top + layout.spreader_gap + half[2] - centre[2]
    moving = Bodies(("s1",), (lifter,), np.zeros(1, np.int64), np.array([[x, y, lift]]),
                    np.array([[1.0, 0.0, 0.0, 0.0]]))
    return Yard(world, moving)
