"""Every way of answering behind one interface, so that each is timed and scored alike.

A :class:`Method` has ``one(*pair)`` (one pair, 1-D inputs: the call a simulator makes for a
single contact, timed at N = 1) and ``batch(args, detail)`` (N pairs as (n, .) arrays, returning
an :class:`Answer`; timed for the throughput). Vectorised methods (the exact solver and the
learned predictors) answer a batch in one call; python-fcl has no batch API, so its methods
(Box-Box and the polygon meshes) loop over the pairs in Python, as a user of python-fcl would.

Learned methods come from ``models.load_predictor(name)``. When that function or the bundle is
missing, or loading fails, the method is kept with ``unavailable`` set to the reason, and the
report says "not available: <reason>": no figure is ever made up for it.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from impactnet.training.bench.paper import polygon as pg

#: The learned predictors, by their ``models.load_predictor`` names.
LEARNED = ("single", "committee", "auto")
#: FCL Box-Box request: python-fcl's analytic box-box returns at most 4 contacts.
FCL_BOX_MAX_CONTACTS = 8


@dataclass
class Answer:
    """What every method answers for N pairs (world frame, metres; normal from A to B)."""

    colliding: np.ndarray  # (n,) bool
    point: np.ndarray  # (n, 3) impact point
    normal: np.ndarray  # (n, 3) unit normal (0 where the method says "no contact")
    # (n,) impactnet.models.contacts codes; None: no types
    contact_type_code: np.ndarray | None = None
    extra: dict = field(default_factory=dict)  # per-method diagnostics (counts, variants)

    def take(self, rows) -> Answer:
        """The answers of ``rows`` (an index array); ``extra`` is not carried over."""
        types = None if self.contact_type_code is None else self.contact_type_code[rows]
        return Answer(self.colliding[rows], self.point[rows], self.normal[rows], types)

    @classmethod
    def from_contacts(cls, contacts) -> Answer:
        """From a ``impactnet.models.contacts.Contacts`` (exact and learned predictors)."""
        extra = {}
        if getattr(contacts, "predictor", None) is not None:
            names, counts = np.unique(np.asarray(contacts.predictor, dtype=str),
                                      return_counts=True)
            extra["answered_by"] = {str(k): int(v) for k, v in zip(names, counts)}
        colliding = np.asarray(contacts.colliding, bool)
        types = np.asarray(contacts.contact_type_code)
        if colliding.any() and not types[colliding].any():  # "none" on every contact: the
            types = None  # predictor gives no types (single), rather than being always wrong
        return cls(colliding, np.asarray(contacts.point), np.asarray(contacts.normal), types,
                   extra)


@dataclass
class Method:
    """One way of answering; see the module docstring."""

    name: str  # row label, e.g. "exact", "fcl box-box", "polygon n=8", "committee"
    family: str  # "exact", "fcl", "polygon", "learned" or "other"
    one: Callable | None = None  # (*six 1-D arrays) -> anything; the N = 1 call
    batch: Callable | None = None  # (args: six (n, .) arrays, detail: bool) -> Answer
    vectorised: bool = True  # False: batch is a Python loop over the pairs
    unavailable: str | None = None  # why the method cannot run; None when it can
    prepare: Callable | None = None  # (pose_set) -> None, untimed set-up (meshes)
    info: dict = field(default_factory=dict)  # grid size, triangles, rule, version


def predictor_method(name: str, predictor: Callable, family: str = "other") -> Method:
    """A method from any callable with ``impactnet.models.box.exact.box_box``'s signature."""

    def batch(args, detail=False):
        return Answer.from_contacts(predictor(*args))

    info = {"version": str(getattr(predictor, "version", ""))} if family == "learned" else {}
    return Method(name, family, one=predictor, batch=batch, info=info)


def exact_method() -> Method:
    """The exact solver, ``impactnet.models.box.exact.box_box`` (the reference of every error
    column)."""
    from impactnet.models.box.exact import box_box

    return predictor_method("exact", box_box, "exact")


def learned_methods(names=LEARNED, bundle=None) -> list[Method]:
    """``models.load_predictor(name)`` for each name, on the bundle's learned path (its
    recorded per-pair decisions lifted: :func:`learned_bundle`, so that an exact-only pair is
    measured as its models answer it); unavailable ones carry the reason."""
    from impactnet.models import load_predictor
    from impactnet.models.predictors import DEFAULT_BUNDLE

    methods = []
    try:
        learned, _ = learned_bundle(DEFAULT_BUNDLE if bundle is None else bundle)
    except Exception as exc:  # noqa: BLE001 - reported per method, not raised
        return [Method(name, "learned", unavailable=f"{type(exc).__name__}: {exc}")
                for name in names]
    for name in names:
        try:
            predictor = load_predictor(name, learned)
        except Exception as exc:  # noqa: BLE001 - any load failure is reported, not raised
            methods.append(Method(name, "learned", unavailable=f"{type(exc).__name__}: {exc}"))
            continue
        methods.append(predictor_method(name, predictor, "learned"))
    return methods


def learned_bundle(bundle) -> tuple:
    """(the bundle with its recorded decisions lifted, {pair: the recorded ``serve``}).

    ``bundle``: a bundle folder or a store (its ``current``), read with its checksums verified
    (:func:`lift_decisions`).
    """
    from impactnet.models.bundle.store import resolve_bundle
    from impactnet.models.learned.bundle_loader import read_bundle

    served = read_bundle(resolve_bundle(bundle))
    recorded = {key: pair.serve if pair.decision is not None else None
                for key, pair in served.pairs.items()}
    return lift_decisions(served), recorded


def lift_decisions(served):
    """``served`` (a Bundle) serving every pair by its learned models: what is timed and scored
    is then the learned path itself, never the exact solver that an exact-only pair is served
    by."""
    from impactnet.models.bundle.format import SERVE_LEARNED

    return replace(served, pairs={key: replace(pair, serve=SERVE_LEARNED, decision=None)
                                  for key, pair in served.pairs.items()})


def _loop(one_pair: Callable, args, detail: bool, extras: tuple[str, ...] = ()) -> Answer:
    """Run ``one_pair`` over the rows of ``args``; it returns (colliding, point, normal, ...)."""
    n = len(args[0])
    colliding = np.zeros(n, bool)
    point, normal = np.zeros((n, 3)), np.zeros((n, 3))
    collected = {key: [] for key in extras}
    for i in range(n):
        hit, p, v, *more = one_pair(*(a[i] for a in args))
        colliding[i], point[i], normal[i] = hit, p, v
        if detail:
            for key, value in zip(extras, more):
                collected[key].append(value)
    return Answer(colliding, point, normal, None, collected if detail else {})


def fcl_box_method() -> Method:
    """python-fcl's analytic Box-Box (``fcl.Box``, full side lengths), pair by pair.

    Point: the depth-weighted mean of FCL's contacts (at most 4: FCL culls the face manifold),
    on the mid-surface; normal: FCL's (o1 = A towards o2 = B, shared by its contacts).
    """
    try:
        import fcl
    except ImportError as exc:
        return Method("fcl box-box", "fcl", unavailable=f"python-fcl is not installed ({exc})")
    request = fcl.CollisionRequest(num_max_contacts=FCL_BOX_MAX_CONTACTS, enable_contact=True)
    objects: dict[tuple, object] = {}

    def obj(size, slot):
        key = (slot, *(float(x) for x in size))
        if key not in objects:
            objects[key] = fcl.CollisionObject(fcl.Box(*size))
        return objects[key]

    def one(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
        obj_a, obj_b = obj(size_a, 0), obj(size_b, 1)
        obj_a.setTransform(fcl.Transform(quaternion_a, position_a))  # q = (w, x, y, z)
        obj_b.setTransform(fcl.Transform(quaternion_b, position_b))
        result = fcl.CollisionResult()
        fcl.collide(obj_a, obj_b, request, result)
        contacts = result.contacts
        if not contacts:
            return False, 0.5 * (np.asarray(position_a) + np.asarray(position_b)), np.zeros(3)
        if len(contacts) == 1:  # vertex-face, edge-edge: the point itself
            return True, contacts[0].pos, contacts[0].normal
        depths = [c.penetration_depth for c in contacts]  # <= 4: plain Python is cheapest
        total = sum(depths)
        weights = [d / total for d in depths] if total > 0.0 else [1.0 / len(depths)] * len(
            depths)
        point = sum(w * c.pos for w, c in zip(weights, contacts))
        return True, point, contacts[0].normal

    return Method("fcl box-box", "fcl", one=one,
                  batch=lambda args, detail=False: _loop(one, args, detail),
                  vectorised=False, info={"request": {"num_max_contacts": FCL_BOX_MAX_CONTACTS,
                                                      "enable_contact": True}})


def polygon_method(n: int) -> Method:
    """The paper's polygon method at grid size ``n`` (see
    :mod:`impactnet.training.bench.paper.polygon`)."""
    try:
        method = pg.PolygonMethod(pg.PolygonConfig(n))
    except ImportError as exc:
        return Method(f"polygon n={n}", "polygon",
                      unavailable=f"python-fcl is not installed ({exc})")

    def one_detailed(*pair):
        hit, point, normal, count = method.one(*pair)
        variants = pg.rule_variants(*method.last_contacts) if hit else None
        return hit, point, normal, count, variants

    def batch(args, detail=False):
        if detail:
            return _loop(one_detailed, args, True, ("contacts", "variants"))
        return _loop(method.one, args, False)

    return Method(method.name, "polygon", one=method.one, batch=batch, vectorised=False,
                  prepare=lambda poses: method.prepare(np.concatenate([poses.size_a,
                                                                       poses.size_b])),
                  info={"grid": n, "triangles_per_box": 12 * n * n, "rule": pg.RULE,
                        "max_contacts": method.config.max_contacts})


def default_methods(grid_sizes=pg.GRID_SIZES, learned=LEARNED, bundle=None) -> list[Method]:
    """exact, FCL Box-Box, the polygon method at each grid size, then the learned ones."""
    return [exact_method(), fcl_box_method(), *(polygon_method(n) for n in grid_sizes),
            *learned_methods(learned, bundle)]
