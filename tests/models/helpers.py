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


#: Labels of :func:`labelled_rows`: the fields of `Contacts` a learned model is trained on.
LABELS = ("colliding", "point", "normal", "depth", "contact_type_code", "feature_a", "feature_b",
          "axis", "manifold_count")
#: Share of rows pulled apart instead of pushed in (rows without contact).
SEPARATED_SHARE = 0.05


def labelled_rows(size_a, size_b, n: int, seed: int) -> dict:
    """``n`` first contacts of one box pair, labelled by the exact solver, for the tests of the
    learned side: an equal share of every orientation family of
    :func:`impactnet.models.geometry.poses.first_contact_poses`, shuffled. Columns: the six
    inputs (:data:`KEYS`), ``family`` (int8), ``push_depth`` (n,) and :data:`LABELS`."""
    from impactnet.models.box.exact import box_box
    from impactnet.models.geometry.poses import ORIENTATIONS, first_contact_poses

    rng = np.random.default_rng(seed)
    counts = np.diff(np.linspace(0, n, len(ORIENTATIONS) + 1).round().astype(int))
    parts = []
    for family, (orientation, count) in enumerate(zip(ORIENTATIONS, counts, strict=True)):
        poses = first_contact_poses(int(count), np.asarray(size_a, float),
                                    np.asarray(size_b, float), rng,
                                    separated_share=SEPARATED_SHARE, orientation=orientation)
        poses["family"] = np.full(count, family, dtype=np.int8)
        parts.append(poses)
    order = rng.permutation(n)
    rows = {k: np.concatenate([p[k] for p in parts])[order]
            for k in (*KEYS, "family", "push_depth")}
    labels = box_box(*(rows[k] for k in KEYS))
    rows.update({name: getattr(labels, name) for name in LABELS})
    return rows


def in_threads(work, count: int = 8, timeout: float = 120.0) -> list:
    """``work(k)`` run in ``count`` threads at once (k = 0 .. count - 1); their results, in
    order. The first exception a thread raised is raised here."""
    import threading

    results, errors = [None] * count, []

    def run(k: int) -> None:
        try:
            results[k] = work(k)
        except Exception as exc:  # noqa: BLE001 - raised below
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(count)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout)
    if errors:
        raise errors[0]
    return results
