"""Shared helpers of the model tests (not a test module)."""
import numpy as np

#: The six inputs of a box pair, in `box_box` order.
KEYS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
#: Point agreement (x pair scale) of two solves of the same contact.
POINT_TOL_REL = 1e-9
#: Rounding units of the world coordinates that an input change of "rounding level" may move
#: the depths by (a rigid motion, a swap or another summation order).
DEPTH_NOISE_ULPS = 100


def scale_of(poses):
    """Pair scale (metres), shape (n,): the mean of the two largest edges."""
    return 0.5 * (poses["size_a"].max(1) + poses["size_b"].max(1))


def point_tolerance(poses, depth, rel=POINT_TOL_REL):
    """Allowed point change (metres) under a rounding-level change of the input, shape (n,).

    The depth-weighted point of a manifold of extent L and depth d moves by L * dd / d when
    the depths move by dd. A rounding-level change of the input moves the depths by
    dd ~ DEPTH_NOISE_ULPS ulps of the world coordinates M, so the bound is
    ``rel * L + DEPTH_NOISE_ULPS * eps * M * L / d``: conditioning, not error, and it only
    matters when the depth is tiny next to the box sizes (the 1 mm sheet pressed 10 um).
    """
    scale = scale_of(poses)
    magnitude = np.maximum(np.abs(poses["position_a"]).max(1),
                           np.abs(poses["position_b"]).max(1)) + scale
    noise = DEPTH_NOISE_ULPS * np.finfo(float).eps * magnitude
    return rel * scale + noise * scale / np.maximum(depth, 1e-12 * scale)


def assert_finite(contacts):
    """Every float array of a `Contacts` is finite (no NaN, no Inf)."""
    for name, value in contacts.arrays().items():
        if value.dtype.kind == "f":
            assert np.isfinite(value).all(), name
