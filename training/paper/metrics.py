"""Error measures of the paper reproduction: ME, MAE, RMSE (raw and with wrapped azimuths), per
output, and their geometric meaning (normal angle in degrees, point error as % of the edge).

Errors are ``predicted - desired`` in radians. ME, MAE and RMSE pool all four outputs of all
patterns (N x 4 numbers), as the paper's single figure per cell implies. "Wrapped" errors map
the azimuth errors (outputs 1 and 3) into [-pi, pi) first, so that a desired +pi predicted as
-pi counts as no error; elevations have no seam and are never wrapped.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.spherical import from_spherical, ray_to_box_surface, wrap_angle
from impactnet.models.metrics import angle_deg, summarise
from impactnet.training.paper.data import AZIMUTH_COLUMNS, OUTPUT_NAMES


def errors(predicted, desired, wrap: bool = False) -> np.ndarray:
    """``predicted - desired`` (n, 4), radians; azimuth columns wrapped when ``wrap``."""
    e = np.asarray(predicted, dtype=np.float64) - np.asarray(desired, dtype=np.float64)
    if wrap:
        e[:, AZIMUTH_COLUMNS] = wrap_angle(e[:, AZIMUTH_COLUMNS])
    return e


def summary(e) -> dict[str, float]:
    """ME, MAE and RMSE over every entry of ``e`` (all outputs, all patterns)."""
    e = np.asarray(e, dtype=np.float64)
    return {"ME": float(e.mean()), "MAE": float(np.abs(e).mean()),
            "RMSE": float(np.sqrt(np.mean(e * e)))}


def per_output(e) -> dict[str, dict[str, float]]:
    """:func:`summary` of each output column, keyed by its name."""
    return {name: summary(np.asarray(e)[:, i]) for i, name in enumerate(OUTPUT_NAMES)}


def normal_error_deg(predicted, desired) -> np.ndarray:
    """Angle (degrees) between the predicted and desired force directions (outputs 3, 4)."""
    p, d = np.asarray(predicted), np.asarray(desired)
    return angle_deg(from_spherical(p[:, 2], p[:, 3]), from_spherical(d[:, 2], d[:, 3]))


def point_error_percent(predicted, desired, size, exact_point=None) -> np.ndarray:
    """Distance between impact points as % of the box edge (``size`` (3,), a cube's edge is
    ``size[0]``).

    The predicted point is where the ray from A's centre along the predicted direction (outputs
    1, 2) leaves A. It is compared with the same construction on the desired direction, or with
    ``exact_point`` (n, 3, A's frame, metres) when given: the latter also counts the
    centre of pressure's offset below the surface (up to half the depth) that the angles
    cannot carry.
    """
    p, d = np.asarray(predicted), np.asarray(desired)
    size = np.asarray(size, dtype=np.float64)
    guess = ray_to_box_surface(from_spherical(p[:, 0], p[:, 1]), size)
    truth = (ray_to_box_surface(from_spherical(d[:, 0], d[:, 1]), size) if exact_point is None
             else np.asarray(exact_point, dtype=np.float64))
    return 100.0 * np.linalg.norm(guess - truth, axis=1) / size[0]


def evaluate(predicted, desired, size, exact_point) -> dict:
    """Every measure of one set: raw and wrapped tables, per output, geometric distributions."""
    raw, wrapped = errors(predicted, desired), errors(predicted, desired, wrap=True)
    return {
        "raw": summary(raw),
        "wrapped": summary(wrapped),
        "per_output_raw": per_output(raw),
        "per_output_wrapped": per_output(wrapped),
        "normal_error_deg": summarise(normal_error_deg(predicted, desired)),
        "point_error_percent_of_edge": summarise(
            point_error_percent(predicted, desired, size)),
        "point_error_vs_exact_percent_of_edge": summarise(
            point_error_percent(predicted, desired, size, exact_point)),
        "seam_share": float(np.mean(np.abs(raw[:, AZIMUTH_COLUMNS]) > np.pi)),
    }
