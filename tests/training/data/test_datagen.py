"""Data generation: seeded, labelled by the exact solver, in contact (or separated) as drawn,
with the orientation families in their shares."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.box.exact import box_box
from impactnet.models.box.tolerances import REGION_DEPTH_TOL_REL
from impactnet.models.contacts import CONTACT_TYPE_CODES
from impactnet.models.geometry.poses import AXIS_ALIGNED_ROTATIONS, ORIENTATIONS, TILT_RANGE
from impactnet.models.scenes import load_scene, parse_scene
from impactnet.training.data.datagen import (
    COLUMN_SPECS,
    INPUT_COLUMNS,
    LABEL_COLUMNS,
    DatagenConfig,
    family_counts,
    generate_dataset,
    generate_pairs,
    pair_seed,
)
from impactnet.training.data.dataset_io import load_dataset

#: Small chunks, so that every test crosses chunk boundaries.
CONFIG = DatagenConfig(chunk_size=128)
C20, C40 = (6.058, 2.438, 2.591), (12.192, 2.438, 2.591)
SPREADER = (12.0, 2.35, 0.8)
#: Round-off allowance of depths, relative to the largest edge of the pair (dimensionless).
DEPTH_TOL_REL = 1e-12


def mini_scene(pairs):
    """A scene with the given (a, b) pairs over three bodies."""
    return parse_scene({
        "scene": {"name": "mini", "depth_fraction": [0.0, 0.01]},
        "accuracy": {"normal_deg": 1.0, "point_fraction": 0.02},
        "bodies": {"c20": {"size": list(C20)}, "c40": {"size": list(C40)},
                   "spreader": {"size": list(SPREADER)}},
        "pairs": [{"a": a, "b": b} for a, b in pairs]})


@pytest.fixture(scope="module")
def crane(tmp_path_factory):
    """The default scene's dataset, 400 rows per pair, loaded back (arrays, manifest)."""
    folder = tmp_path_factory.mktemp("crane")
    generate_dataset(load_scene("quay_crane"), 400, 11, CONFIG, folder, progress=False)
    return load_dataset(folder / "quay_crane.npz")


def relative_rotation(arrays):
    """R_ab = R_a^T R_b of every row, shape (n, 3, 3)."""
    rot = [Rotation.from_quat(arrays[k], scalar_first=True).as_matrix()
           for k in ("quaternion_a", "quaternion_b")]
    return np.swapaxes(rot[0], 1, 2) @ rot[1]


def misalignment(rot_ab):
    """Angle (rad) from each R_ab to the nearest axis-aligned rotation."""
    trace = np.einsum("nij,kij->nk", rot_ab, AXIS_ALIGNED_ROTATIONS).max(axis=1)
    return np.arccos(np.clip((trace - 1) / 2, -1, 1))


def test_same_seed_same_arrays_other_seed_other_arrays():
    a = generate_pairs(C20, C40, 700, 5, CONFIG, progress=False)
    b = generate_pairs(C20, C40, 700, np.random.SeedSequence(5), CONFIG, progress=False)
    c = generate_pairs(C20, C40, 700, 6, CONFIG, progress=False)
    assert list(a) == list(COLUMN_SPECS)
    for name, (dtype, width) in COLUMN_SPECS.items():
        assert a[name].dtype == np.dtype(dtype) and a[name].shape[1:] == ((width,) if width
                                                                          else ())
        assert a[name].tobytes() == b[name].tobytes(), name
    assert a["position_b"].tobytes() != c["position_b"].tobytes()


def test_adding_or_reordering_pairs_keeps_each_pairs_rows():
    small = mini_scene([("c20", "c40"), ("c40", "spreader")])
    large = mini_scene([("c20", "spreader"), ("c40", "spreader"), ("c20", "c40")])
    rows = {}
    for scene in (small, large):
        for k, pair in enumerate(scene.pairs):
            size_a, size_b = scene.pair_sizes()[k]
            data = generate_pairs(size_a, size_b, 300, pair_seed(9, pair), CONFIG,
                                  progress=False)
            rows.setdefault(pair.key, []).append(data["position_b"].tobytes())
    assert all(len(set(v)) == 1 for v in rows.values())
    assert len(rows) == 3


def test_labels_equal_a_fresh_exact_call_on_the_stored_poses(crane):
    arrays, _ = crane
    fresh = box_box(*(arrays[name] for name in INPUT_COLUMNS))  # one call, not chunked
    for name in LABEL_COLUMNS:
        np.testing.assert_array_equal(getattr(fresh, name), arrays[name], err_msg=name)


@pytest.mark.parametrize("depth_fraction", [(0.0, 0.01), (0.001, 0.002), (0.0, 0.0)])
def test_contact_share_touches_within_the_drawn_depth(depth_fraction):
    config = DatagenConfig(chunk_size=256, depth_fraction=depth_fraction)
    data = generate_pairs(C40, SPREADER, 1500, 2, config, depth_fraction=(0.3, 0.4),
                          progress=False)
    shortest = min(min(C40), min(SPREADER))
    # + the solver's documented slack: a face contact keeps its SAT overlap while the
    # footprint's deepest point is within REGION_DEPTH_TOL_REL of the size of it
    tol = (DEPTH_TOL_REL + REGION_DEPTH_TOL_REL) * max(max(C40), max(SPREADER))
    pushed = data["push_depth"] >= 0
    assert pushed.mean() > 0.9
    push = data["push_depth"][pushed]
    lo, hi = depth_fraction  # the config's override wins over the scene's range
    assert (push >= lo * shortest).all() and (push <= hi * shortest + tol).all()
    assert data["colliding"][pushed].all()
    depth = data["depth"][pushed]
    assert (depth >= 0).all() and (depth <= push + tol).all()
    assert (data["contact_type_code"][pushed] > 0).all()


def test_separated_share_is_separated():
    config = DatagenConfig(chunk_size=500, separated_share=0.2)
    data = generate_pairs(C20, C20, 3000, 4, config, progress=False)
    out = data["push_depth"] < 0
    assert abs(out.mean() - 0.2) < 0.01
    assert not data["colliding"][out].any()
    assert (data["depth"][out] == 0).all()
    assert (data["contact_type_code"][out] == CONTACT_TYPE_CODES["none"]).all()
    assert data["colliding"][~out].all()


def test_families_come_in_their_shares_per_chunk():
    config = DatagenConfig(chunk_size=300, uniform_share=0.4, near_parallel_faces_share=0.3,
                           near_parallel_edges_share=0.2, paper_share=0.1)
    data = generate_pairs(C20, C40, 1000, 8, config, progress=False)
    expected = sum(family_counts(m, config.shares) for m in (300, 300, 300, 100))
    np.testing.assert_array_equal(np.bincount(data["family"], minlength=4), expected)
    first_chunk = np.bincount(data["family"][:300], minlength=4)
    np.testing.assert_array_equal(first_chunk, [120, 90, 60, 30])
    # Shuffled within the chunk: the first rows are not all of one family.
    assert len(np.unique(data["family"][:20])) > 1


def test_near_parallel_families_are_near_parallel(crane):
    arrays, _ = crane
    rot_ab = relative_rotation(arrays)
    family = np.asarray(ORIENTATIONS)[arrays["family"]]
    faces, edges = family == "near_parallel_faces", family == "near_parallel_edges"
    assert faces.sum() > 400 and edges.sum() > 400  # 15 % of 4000 rows each
    assert misalignment(rot_ab[faces]).max() <= TILT_RANGE[1] * (1 + 1e-9)
    # One of B's axes within the tilt range of one of A's axes ...
    best = np.abs(rot_ab[edges]).max(axis=(1, 2))
    assert best.min() >= np.cos(TILT_RANGE[1]) - 1e-12
    # ... but, as a rule, not face-parallel; nor are the uniform rows.
    assert np.median(misalignment(rot_ab[edges])) > 0.1
    assert np.median(misalignment(rot_ab[family == "uniform"])) > 0.1
    # Face-parallel rows produce manifold contacts (face-face / edge-face) often.
    codes = arrays["contact_type_code"][faces & arrays["colliding"]]
    assert np.isin(codes, [CONTACT_TYPE_CODES["face-face"], CONTACT_TYPE_CODES["edge-face"],
                           CONTACT_TYPE_CODES["face-edge"]]).mean() > 0.3


def test_paper_family_keeps_the_papers_euler_ranges(crane):
    arrays, _ = crane
    rows = np.asarray(ORIENTATIONS)[arrays["family"]] == "paper"
    angles = Rotation.from_matrix(relative_rotation(arrays)[rows]).as_euler("ZYX")
    assert np.abs(angles).max() <= np.pi / 2 + 1e-9


@pytest.mark.parametrize("seed", range(5))
def test_family_counts_sum_to_n_and_follow_the_shares(seed):
    rng = np.random.default_rng(seed)
    shares = rng.dirichlet(np.ones(4))
    for n in rng.integers(0, 10_000, 20):
        counts = family_counts(int(n), shares)
        assert counts.sum() == n and (counts >= 0).all()
        assert (np.abs(counts - n * shares) <= 1).all()


@pytest.mark.parametrize("kwargs", [
    {"uniform_share": 0.5},  # shares sum to 0.95
    {"uniform_share": -0.05, "paper_share": 0.75},
    {"separated_share": 1.0},
    {"separated_share": -0.1},
    {"chunk_size": 0},
    {"chunk_size": 10.5},
    {"depth_fraction": (0.02, 0.01)},
    {"depth_fraction": (-0.01, 0.01)},
])
def test_invalid_config_is_refused(kwargs):
    with pytest.raises(ValueError):
        DatagenConfig(**kwargs)


def test_negative_seed_is_refused(tmp_path):
    with pytest.raises(ValueError, match="seed"):
        generate_pairs(C20, C40, 10, -1, progress=False)
    with pytest.raises(ValueError, match="seed"):
        generate_dataset(mini_scene([("c20", "c40")]), 10, -1, out_dir=tmp_path,
                         progress=False)


def test_progress_bar_only_when_asked(capsys):
    generate_pairs(C20, C40, 50, 0, progress=False)
    assert capsys.readouterr().err == ""
    generate_pairs(C20, C40, 50, 0, progress=True)
    assert "pair" in capsys.readouterr().err
    generate_pairs(C20, C40, 50, 0)  # None: stderr is not a terminal under pytest
    assert capsys.readouterr().err == ""
