"""crf_jax.save / load: round trip for every model type (the kind read from the file), and clear errors
for bad files."""
import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import crf_jax
from lfd_common import save_arrays


def _models():
    key = jax.random.PRNGKey(0)
    chain = crf_jax.init_chain(4, 3, connectivity=1, key=key, scale=0.5)
    return {
        "ChainCRF": chain,
        "HCRF": crf_jax.init_hcrf(key, 4, 3, 2, connectivity=2),
        "FCRF": crf_jax.FCRF(chain, crf_jax.init_chain(4, 2, connectivity=1, key=key, scale=0.3),
                             jnp.arange(6.0).reshape(3, 2)),
        "LinearModel": crf_jax.LinearModel(jnp.ones((4, 3)), jnp.arange(3.0)),
    }


STRUCTURES = {
    "ChainCRF": crf_jax.ChainStructure(n_labels=3, n_features=4, connectivity=1),
    "HCRF": crf_jax.HCRFStructure(n_labels=3, n_hidden=2, n_features=4, connectivity=2),
    "FCRF": crf_jax.FCRFStructure(n_actions=3, n_objects=2, n_features=4, connectivity=1),
    "LinearModel": crf_jax.LinearStructure(n_labels=3, n_features=4),
}


@pytest.mark.parametrize("name", ["ChainCRF", "HCRF", "FCRF", "LinearModel"])
def test_round_trip(tmp_path, name):
    model = _models()[name]
    assert model.structure == STRUCTURES[name]
    path = crf_jax.save(tmp_path / "model", model)
    assert path.suffix == ".npz"
    loaded = crf_jax.load(path)  # no type argument: the kind comes from the file
    assert type(loaded) is type(model) and loaded.structure == model.structure
    chex.assert_trees_all_equal_shapes(loaded, model)
    for a, b in zip(jax.tree_util.tree_leaves(model), jax.tree_util.tree_leaves(loaded)):
        np.testing.assert_array_equal(a, b)
    assert type(crf_jax.load(str(tmp_path / "model"), type(model))) is type(model)  # the optional check
    if name == "ChainCRF":  # the loaded model predicts the same
        X = np.random.default_rng(0).normal(size=(2, 5, 4))
        np.testing.assert_array_equal(crf_jax.predict(model, X), crf_jax.predict(loaded, X))


def test_structures_validate_their_fields():
    with pytest.raises(ValueError, match="n_labels"):
        crf_jax.ChainStructure(n_labels=0, n_features=2)
    with pytest.raises(ValueError, match="connectivity"):
        crf_jax.HCRFStructure(n_labels=2, n_hidden=2, n_features=2, connectivity=-1)
    with pytest.raises(ValueError, match="n_objects"):
        crf_jax.FCRFStructure(n_actions=2, n_objects=1.5, n_features=2)


def test_bad_files(tmp_path):
    models = _models()
    path = crf_jax.save(tmp_path / "chain.npz", models["ChainCRF"])
    with pytest.raises(ValueError, match="holds a ChainCRF, expected a HCRF"):
        crf_jax.load(path, crf_jax.HCRF)
    with pytest.raises(FileNotFoundError):
        crf_jax.load(tmp_path / "missing.npz")
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(path.read_bytes()[:200])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        crf_jax.load(truncated)
    structure = {"structure": {"n_labels": 3, "n_features": 4, "connectivity": 0}}
    # right kind, arrays that disagree with the stored structure
    bad = save_arrays(tmp_path / "bad", "crf_jax.ChainCRF", {"weights": np.zeros((1, 4, 3)), "bias": np.zeros(2),
                                                              "trans": np.zeros((3, 3))}, structure)
    with pytest.raises(ValueError, match="'bias': expected shape"):
        crf_jax.load(bad)
    missing = save_arrays(tmp_path / "missing_arr", "crf_jax.ChainCRF", {"weights": np.zeros((1, 4, 3))}, structure)
    with pytest.raises(ValueError, match="missing \\['bias', 'trans'\\]"):
        crf_jax.load(missing)
    no_structure = save_arrays(tmp_path / "old", "crf_jax.ChainCRF", {"weights": np.zeros((1, 4, 3))})
    with pytest.raises(ValueError, match="no structure"):
        crf_jax.load(no_structure)
    nan = save_arrays(tmp_path / "nan", "crf_jax.LinearModel", {"weights": np.full((2, 2), np.nan),
                                                                "bias": np.zeros(2)},
                      {"structure": {"n_labels": 2, "n_features": 2}})
    with pytest.raises(ValueError, match="NaN"):
        crf_jax.load(nan)
    other = save_arrays(tmp_path / "other", "phmm_jax.HMM", {"w": np.zeros(2)})
    with pytest.raises(ValueError, match="expected one of"):
        crf_jax.load(other)
    with pytest.raises(ValueError, match="model"):
        crf_jax.save(tmp_path / "x", {"weights": 1})
    mismatched = crf_jax.FCRF(models["ChainCRF"], crf_jax.init_chain(5, 2, connectivity=1), jnp.zeros((3, 2)))
    with pytest.raises(ValueError, match="object/weights"):
        crf_jax.save(tmp_path / "fcrf", mismatched)  # the two chains must read the same features
