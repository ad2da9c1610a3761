"""crf_jax.save / load: round trip for every model type, and clear errors for bad files."""
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


@pytest.mark.parametrize("name", ["ChainCRF", "HCRF", "FCRF", "LinearModel"])
def test_round_trip(tmp_path, name):
    model = _models()[name]
    path = crf_jax.save(tmp_path / "model", model)
    assert path.suffix == ".npz"
    loaded = crf_jax.load(path, type(model))
    assert type(loaded) is type(model)
    for a, b in zip(jax.tree_util.tree_leaves(model), jax.tree_util.tree_leaves(loaded)):
        np.testing.assert_array_equal(a, b)
    if name == "ChainCRF":  # the loaded model predicts the same
        X = np.random.default_rng(0).normal(size=(2, 5, 4))
        np.testing.assert_array_equal(crf_jax.predict(model, X), crf_jax.predict(loaded, X))


def test_bad_files(tmp_path):
    models = _models()
    path = crf_jax.save(tmp_path / "chain.npz", models["ChainCRF"])
    with pytest.raises(ValueError, match="expected a 'crf_jax.HCRF'"):
        crf_jax.load(path, crf_jax.HCRF)
    with pytest.raises(ValueError, match="model_type"):
        crf_jax.load(path, dict)
    with pytest.raises(FileNotFoundError):
        crf_jax.load(tmp_path / "missing.npz", crf_jax.ChainCRF)
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(path.read_bytes()[:200])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        crf_jax.load(truncated, crf_jax.ChainCRF)
    # right kind, wrong contents
    bad = save_arrays(tmp_path / "bad", "crf_jax.ChainCRF", {"weights": np.zeros((1, 4, 3)), "bias": np.zeros(2),
                                                              "trans": np.zeros((3, 3))})
    with pytest.raises(ValueError, match="shapes"):
        crf_jax.load(bad, crf_jax.ChainCRF)
    missing = save_arrays(tmp_path / "missing_arr", "crf_jax.ChainCRF", {"weights": np.zeros((1, 4, 3))})
    with pytest.raises(ValueError, match="lacks the array 'bias'"):
        crf_jax.load(missing, crf_jax.ChainCRF)
    nan = save_arrays(tmp_path / "nan", "crf_jax.LinearModel", {"weights": np.full((2, 2), np.nan), "bias": np.zeros(2)})
    with pytest.raises(ValueError, match="not finite"):
        crf_jax.load(nan, crf_jax.LinearModel)
    with pytest.raises(ValueError, match="model"):
        crf_jax.save(tmp_path / "x", {"weights": 1})
