"""The expert of each contact region of a compound pair, chosen by measurement (issue #21,
step 2).

A region is a part pair and a coarse region of its contact
(:mod:`impactnet.models.learned.compound.experts`,
:mod:`impactnet.models.learned.compound.regions`). For the :attr:`ExpertConfig.max_regions` regions
with the most training contacts (at least :attr:`ExpertConfig.min_rows`), a committee of K tanh MLPs
is fitted (one :class:`impactnet.training.fit.torch_mlp.StackedMLP` of K x regions networks, each on
its region's rows; members differ by their initial weights) to the contact in A's part frame, by
squared error in units of the scene's tolerances. On the validation rows the committee's p99 errors
are compared with the tolerances (depth 2 % of the depth range, normal ``accuracy.normal_deg``,
point ``Scene.point_tolerance_m`` of the two parts): the region takes the committee only where all
three are met, else the exact part-pair solver (cheaper for box parts and exact everywhere). Every
region's figures go into the bundle.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from impactnet.models.bundle.compound_format import GROUP_INPUTS, PART_CONTACT_OUTPUTS
from impactnet.models.learned.compound.experts import N_EXPERT_OUTPUTS, RegionCommittee
from impactnet.models.learned.compound.groups import PartGroup, bounds_centre, group_features
from impactnet.models.learned.compound.regions import describe_region
from impactnet.models.learned.mlp import MLP, MLPSpec
from impactnet.models.metrics import angle_deg
from impactnet.training.compound.rows import CompoundRows
from impactnet.training.fit.loop import FitConfig, GroupRows, fit
from impactnet.training.fit.torch_mlp import StackedMLP, column_statistics, input_statistics

#: Share of the depth range that the depth tolerance is (issue #21: 2 %).
DEPTH_TOLERANCE_FRACTION = 0.02
#: A served committee answers only where its members agree to within this quantile of their
#: validation spreads (normal angle, depth); beyond, the exact part-pair solver does.
SPREAD_QUANTILE = 0.99


@dataclass(frozen=True)
class ExpertConfig:
    """The committees of a compound pair's regions."""

    members: int = 3  # K, networks per committee
    hidden: tuple[int, ...] = (64, 64)  # hidden widths of a member
    activation: str = "relu"  # hidden activation: relu fits the piecewise-linear depth of a
    # contact (linear in the pose between feature switches) better than tanh
    max_regions: int = 8  # committees are fitted for at most this many regions (most rows)
    min_rows: int = 300  # ... each with at least this many training contacts
    fit: FitConfig = field(default_factory=lambda: FitConfig(
        batch_size=256, steps_per_epoch=100, max_epochs=40, patience=6, val_rows=4096))


@dataclass(frozen=True)
class Tolerances:
    """What a region's answers must meet (p99)."""

    depth_m: float  # depth error, metres
    normal_deg: float  # normal error, degrees


def pair_tolerances(scene, pair) -> tuple[Tolerances, object]:
    """(depth and normal tolerances, ``point_tol(i, j)``: the point tolerance (m) of a contact
    of A's part i and B's part j) of a compound pair of ``scene``."""
    parts_a, parts_b = scene.body(pair.a).parts, scene.body(pair.b).parts
    depth_range = scene.smaller_shortest_edge(pair) * (scene.depth_fraction[1]
                                                       - scene.depth_fraction[0])
    tol = Tolerances(DEPTH_TOLERANCE_FRACTION * depth_range, scene.accuracy.normal_deg)

    def point_tol(i: int, j: int) -> float:
        return scene.point_tolerance_m(pair, parts_a[i].name, parts_b[j].name)
    return tol, point_tol


def _frame(parts_a, parts_b, i: int, j: int) -> PartGroup:
    """Region (i, j) as a group of one part each: the committee members' input frame."""
    return PartGroup(f"{i}/{j}", (i,), (j,), bounds_centre(parts_a, (i,)),
                     bounds_centre(parts_b, (j,)))


def _targets(rows: CompoundRows, members: np.ndarray, frame: PartGroup) -> np.ndarray:
    c = rows.contact
    return np.c_[c["depth"][members], c["normal"][members],
                 c["point"][members] - np.asarray(frame.centre_a), c["pressure"][members]]


def _mse(scale: torch.Tensor):
    def loss(model: StackedMLP, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        return (((model(x) - y) / scale) ** 2).mean(dim=2)
    return loss


def region_errors(pred: np.ndarray, want: np.ndarray) -> dict:
    """p99 depth (m), normal (deg) and point (m) errors of expert outputs (k, 8)."""
    return {"depth_m": float(np.quantile(np.abs(pred[:, 0] - want[:, 0]), 0.99)),
            "normal_deg": float(np.quantile(angle_deg(pred[:, 1:4], want[:, 1:4]), 0.99)),
            "point_m": float(np.quantile(np.linalg.norm(pred[:, 4:7] - want[:, 4:7], axis=1),
                                         0.99))}


def fit_regions(rows: CompoundRows, parts_a, parts_b, point_tol, tol: Tolerances,
                config: ExpertConfig, prefix: str, seed: int):
    """(committees {(i, j, code): RegionCommittee}, region entries {"i/j/code": dict},
    tensors, specs).

    ``point_tol(i, j)`` is the point tolerance (m) of a contact of A's part i and B's part j.
    """
    keys, counts = np.unique(np.c_[rows.part_a, rows.part_b, rows.region][
        np.isin(rows.pose, rows.train)], axis=0, return_counts=True)
    order = np.argsort(-counts, kind="stable")
    chosen = [tuple(int(v) for v in keys[k]) for k in order[:config.max_regions]
              if counts[k] >= config.min_rows]
    entries = {f"{i}/{j}/{code}": {"expert": "exact-part", "train_contacts": int(c),
                                   "region": describe_region(code),
                                   "figures": {"reason": "too few rows for a committee"}}
               for (i, j, code), c in zip(keys.tolist(), counts.tolist())}
    if not chosen:
        return {}, entries, {}, {}
    x, y, train, val, frames = _region_table(rows, parts_a, parts_b, chosen)
    model, spec = _fit_members(x, y, train, val, config, seed)
    committees, tensors, specs = {}, {}, {}
    k = config.members
    for r, ((i, j, code), frame) in enumerate(zip(chosen, frames)):
        names = [f"{prefix}.region_{i}_{j}_{code}.m{m}" for m in range(k)]
        exported = [model.export(r * k + m, name) for m, name in enumerate(names)]
        mlps = tuple(MLP.from_tensors(n, t, spec) for n, t in zip(names, exported))
        outs = np.stack([mlp.forward(x[val[r]].astype(np.float32)) for mlp in mlps])
        entry = entries[f"{i}/{j}/{code}"]
        entry["figures"] = _validation_figures(outs, y[val[r]], tol, point_tol(i, j))
        ratios = entry["figures"]["p99_over_tolerance"]
        if ratios is None or max(ratios.values()) > 1.0:
            continue  # the exact part-pair solver stays this region's expert
        entry |= _committee_entry(rows, names, frame, code, outs)
        specs |= {name: spec.to_dict() for name in names}
        for t in exported:
            tensors |= t
        committees[(i, j, code)] = RegionCommittee(
            i, j, code, frame, mlps, entry["sure_min"], entry["normal_spread_max_deg"],
            entry["depth_spread_max_m"], entry["contact_type_code"], entry["feature_a"],
            entry["feature_b"])
    return committees, entries, tensors, specs


def _members(rows: CompoundRows, i: int, j: int, code: int) -> np.ndarray:
    """The part contacts of region (i, j, code)."""
    return np.flatnonzero((rows.part_a == i) & (rows.part_b == j) & (rows.region == code))


def _region_table(rows: CompoundRows, parts_a, parts_b, chosen):
    """(x (m, 9), y (m, 8), training rows per region, validation rows per region, frames):
    the contacts of the chosen regions, one block per region."""
    x_parts, y_parts, train, val, frames, offset = [], [], [], [], [], 0
    for i, j, code in chosen:
        frame = _frame(parts_a, parts_b, i, j)
        members = _members(rows, i, j, code)
        at = rows.pose[members]
        x_parts.append(group_features(frame, rows.position[at], rows.rotation[at]))
        y_parts.append(_targets(rows, members, frame))
        train.append(offset + np.flatnonzero(np.isin(at, rows.train)))
        val.append(offset + np.flatnonzero(np.isin(at, rows.val)))
        frames.append(frame)
        offset += len(members)
    return np.concatenate(x_parts), np.concatenate(y_parts), train, val, frames


def _fit_members(x, y, train, val, config: ExpertConfig, seed: int):
    """(StackedMLP of K networks per region, their spec), fitted on each region's rows."""
    k = config.members
    spec = MLPSpec(config.activation, (x.shape[1], *config.hidden, N_EXPERT_OUTPUTS),
                   GROUP_INPUTS, PART_CONTACT_OUTPUTS)
    generator = torch.Generator().manual_seed(seed)
    model = StackedMLP(spec, k * len(train), generator)
    in_stats = [input_statistics(x[t]) for t in train for _ in range(k)]
    out_stats = [column_statistics(y[t]) for t in train for _ in range(k)]
    model.set_normalisation(*(np.stack(s) for s in zip(*in_stats)),
                            *(np.stack(s) for s in zip(*out_stats)))
    scale = torch.as_tensor(np.stack([s[1] for s in out_stats]), dtype=torch.float32)[:, None]
    fit(model, _mse(scale), torch.as_tensor(x, dtype=torch.float32),
        torch.as_tensor(y, dtype=torch.float32), GroupRows([t for t in train for _ in range(k)]),
        GroupRows([v if len(v) else t for t, v in zip(train, val) for _ in range(k)]),
        config.fit, generator, desc="committees", progress=False)
    return model, spec


def _validation_figures(outs: np.ndarray, want: np.ndarray, tol: Tolerances,
                        point_tol: float) -> dict:
    """p99 errors of the members' mean (outs (K, m, 8)) on a region's validation contacts."""
    if not len(want):
        return {"validation_contacts": 0, "p99": None, "p99_over_tolerance": None}
    errors = region_errors(outs.mean(axis=0).astype(np.float64), want)
    return {"validation_contacts": int(len(want)), "p99": errors,
            "p99_over_tolerance": {"depth": errors["depth_m"] / tol.depth_m,
                                   "normal": errors["normal_deg"] / tol.normal_deg,
                                   "point": errors["point_m"] / point_tol}}


def _committee_entry(rows: CompoundRows, names, frame: PartGroup, code: int,
                     outs: np.ndarray) -> dict:
    """The manifest fields of a region that takes its committee: members, limits, type."""
    mean = outs.mean(axis=0)
    spread_deg = np.max([angle_deg(o[:, 1:4], mean[:, 1:4]) for o in outs], axis=0)
    spread_depth = outs[:, :, 0].max(axis=0) - outs[:, :, 0].min(axis=0)
    i, j = frame.parts_a[0], frame.parts_b[0]
    return {"expert": "committee", "members": list(names), "sure_min": 0.5,
            "normal_spread_max_deg": float(np.quantile(spread_deg, SPREAD_QUANTILE)),
            "depth_spread_max_m": float(np.quantile(spread_depth, SPREAD_QUANTILE)),
            "frame": {"centre_a": list(frame.centre_a), "centre_b": list(frame.centre_b)}
            } | _most_frequent(rows, i, j, code)


def _most_frequent(rows: CompoundRows, i: int, j: int, code: int) -> dict:
    """The most frequent (contact type, feature_a, feature_b) of a region's training rows."""
    members = _members(rows, i, j, code)
    c = rows.contact
    triples, counts = np.unique(np.c_[c["type"][members], c["feature_a"][members],
                                      c["feature_b"][members]], axis=0, return_counts=True)
    t = triples[int(np.argmax(counts))]
    return {"contact_type_code": int(t[0]), "feature_a": int(t[1]), "feature_b": int(t[2])}
