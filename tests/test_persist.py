import json

import numpy as np
import pytest

from lfd_common import SCHEMA_VERSION, load_arrays, save_arrays

KIND = "tests.Model"


@pytest.fixture
def saved(tmp_path):
    arrays = {"means": np.arange(12.0).reshape(3, 4), "durations": np.array([4, 5, 6], np.int32)}
    config = {"n_states": 3, "covariance": "full", "grid": [2, 2]}
    return save_arrays(tmp_path / "model", KIND, arrays, config), arrays, config


def test_round_trip(saved):
    path, arrays, config = saved
    assert path.suffix == ".npz"
    loaded, loaded_config, version = load_arrays(path, KIND)
    assert version == SCHEMA_VERSION
    assert loaded_config == config
    assert set(loaded) == set(arrays)
    for name, value in arrays.items():
        np.testing.assert_array_equal(loaded[name], value)
        assert loaded[name].dtype == value.dtype


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such model file"):
        load_arrays(tmp_path / "absent.npz", KIND)


def test_truncated_file(saved, tmp_path):
    path = saved[0]
    cut = tmp_path / "cut.npz"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        load_arrays(cut, KIND)


def test_corrupt_bytes(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"this is not a zip archive at all" * 10)
    with pytest.raises(ValueError, match="truncated or corrupt"):
        load_arrays(bad, KIND)


def test_wrong_kind(saved):
    with pytest.raises(ValueError, match="holds a 'tests.Model', expected a 'other.Kind'"):
        load_arrays(saved[0], "other.Kind")


def test_plain_npz_is_not_a_model(tmp_path):
    plain = tmp_path / "plain.npz"
    np.savez(plain, x=np.zeros(3))
    with pytest.raises(ValueError, match="not an lfd-jax model"):
        load_arrays(plain, KIND)


def test_newer_schema_is_refused(tmp_path):
    path = save_arrays(tmp_path / "future", KIND, {"x": np.zeros(2)}, schema_version=SCHEMA_VERSION + 1)
    with pytest.raises(ValueError, match="schema version"):
        load_arrays(path, KIND)


def test_save_rejects_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="reserved"):
        save_arrays(tmp_path / "m", KIND, {"__lfd_meta__": np.zeros(1)})
    with pytest.raises(ValueError, match="object arrays"):
        save_arrays(tmp_path / "m", KIND, {"x": np.array([{}, []], dtype=object)})
    with pytest.raises(ValueError, match="config: not JSON"):
        save_arrays(tmp_path / "m", KIND, {"x": np.zeros(1)}, {"f": object()})
    with pytest.raises(ValueError, match="kind"):
        save_arrays(tmp_path / "m", "", {"x": np.zeros(1)})


def test_metadata_is_readable_json(saved):
    with np.load(saved[0]) as npz:
        meta = json.loads(str(npz["__lfd_meta__"]))
    assert meta["kind"] == KIND and meta["format"] == "lfd-jax"


def test_plain_npy_under_an_npz_name_is_a_clear_error(tmp_path):
    fake = tmp_path / "array.npz"
    with open(fake, "wb") as f:
        np.save(f, np.zeros(3))
    with pytest.raises(ValueError, match="plain .npy array"):
        load_arrays(fake, KIND)


def test_corrupt_metadata_values_are_refused(tmp_path):
    def with_meta(name, **meta):
        path = tmp_path / f"{name}.npz"
        base = {"format": "lfd-jax", "kind": KIND, "schema_version": 1, "config": {}}
        np.savez(path, __lfd_meta__=np.asarray(json.dumps({**base, **meta})), x=np.zeros(2))
        return path

    with pytest.raises(ValueError, match="schema version True"):
        load_arrays(with_meta("bool_version", schema_version=True), KIND)
    with pytest.raises(ValueError, match="config is a list"):
        load_arrays(with_meta("list_config", config=[1, 2]), KIND)


def test_bad_path_and_ragged_arrays_name_the_argument(tmp_path):
    with pytest.raises(ValueError, match="^path: expected a file path"):
        load_arrays(None, KIND)
    with pytest.raises(ValueError, match=r"^arrays\['x'\]: cannot be converted"):
        save_arrays(tmp_path / "m", KIND, {"x": [[1.0, 2.0], [3.0]]})


def test_the_path_given_to_save_loads(tmp_path):
    written = save_arrays(tmp_path / "model", KIND, {"x": np.zeros(2)})
    assert written == tmp_path / "model.npz"
    arrays, _, _ = load_arrays(tmp_path / "model", KIND)
    np.testing.assert_array_equal(arrays["x"], np.zeros(2))
