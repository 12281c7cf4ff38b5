"""Serving state: the service reads the current version of a bundle store."""
from impactnet.models.bundle.store import VERSIONS, set_current
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.service.state import read_for_scene
from tests.models.bundle.test_store import _store


def test_the_service_reads_the_current_version_of_a_store(tmp_path):
    store = _store(tmp_path)
    set_current(store, "v2")
    manifest = read_bundle(store / VERSIONS / "v2").manifest

    class View:  # the scene view read_for_scene checks the bundle's scene against
        name, hash = manifest["scene"]["name"], manifest["scene"]["hash"]

    assert read_for_scene(store, View()).version == manifest["version"]


def test_a_bundle_path_too_long_for_the_file_system_is_a_read_error(tmp_path):
    """Regression (found by the schemathesis reload fuzz): a 5,000-character path made
    ``Path.is_dir`` raise ENAMETOOLONG, and the reload answered 500."""
    import pytest

    from impactnet.service.scene import EMPTY_SCENE
    from impactnet.service.state import LoadError

    with pytest.raises(LoadError) as info:
        read_for_scene(tmp_path / ("0" * 5000), EMPTY_SCENE)
    assert info.value.step == "read"
