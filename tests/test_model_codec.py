"""The generic model persistence of `lfd_common` (structure JSON + parameter pytree, ModelCodec)."""
import dataclasses
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
import pytest

from lfd_common import ArraySpec, ModelCodec, load_model, save_model, save_arrays, structure_from_json


@dataclasses.dataclass(frozen=True)
class Inner:
    n: int
    shape: tuple[int, ...] = (2, 2)

    def __post_init__(self):
        if self.n < 1:
            raise ValueError(f"n: must be >= 1, got {self.n}")


@dataclasses.dataclass(frozen=True)
class Outer:
    inner: Inner
    label: str = "x"
    optional: Inner | None = None


class Params(NamedTuple):
    weights: jnp.ndarray   # (n, D)
    log_probs: jnp.ndarray  # (n,), -inf allowed
    nested: dict


class Toy(NamedTuple):
    params: Params
    outer: Outer


def _check(model: Toy) -> None:
    if not np.allclose(np.exp(np.asarray(model.params.log_probs)).sum(), 1.0, atol=1e-5):
        raise ValueError("log_probs: do not sum to 1 in probability")


# The structure sits in a static field of the model: kept outside the flattened arrays by a
# pytree registration in real libraries; here the codec rebuilds it, so it is stored once as JSON.
CODEC = ModelCodec(
    kind="tests.Toy",
    model_type=Toy,
    structure_type=Outer,
    structure_of=lambda m: m.outer,
    template=lambda s: Toy(Params(ArraySpec((s.inner.n, "D")), ArraySpec((s.inner.n,), finite=False),
                                  {"counts": ArraySpec((s.inner.n,), dtype="int")}), None),
    check=_check,
)


def _toy(n=3, d=4):
    probs = np.full(n, 1.0 / (n - 1))
    probs[0] = 0.0
    params = Params(jnp.arange(n * d, dtype=jnp.float32).reshape(n, d), jnp.log(jnp.asarray(probs)),
                    {"counts": jnp.arange(n, dtype=jnp.int32)})
    return Toy(params, None), Outer(Inner(n, (3, 1)), "toy", None)


def _save(tmp_path, name, n=3, d=4):
    model, outer = _toy(n, d)
    codec = dataclasses.replace(CODEC, structure_of=lambda m: outer)
    return save_model(tmp_path / name, model, [codec]), model, outer


def test_round_trip_keeps_arrays_structure_and_minus_inf(tmp_path):
    path, model, outer = _save(tmp_path, "toy")
    loaded = load_model(path, [CODEC])
    np.testing.assert_array_equal(loaded.params.weights, model.params.weights)
    np.testing.assert_array_equal(loaded.params.log_probs, model.params.log_probs)
    assert loaded.params.nested["counts"].dtype == jnp.int32
    assert loaded.params.log_probs[0] == -jnp.inf
    assert structure_from_json(Outer, {"inner": {"n": 2, "shape": [3, 1]}}) == Outer(Inner(2, (3, 1)))


def test_load_picks_the_codec_from_the_stored_kind(tmp_path):
    path, _, _ = _save(tmp_path, "toy")
    other = dataclasses.replace(CODEC, kind="tests.Other")
    assert isinstance(load_model(path, [other, CODEC]), Toy)
    with pytest.raises(ValueError, match="holds a 'tests.Toy', expected one of \\['tests.Other'\\]"):
        load_model(path, [other])


def test_save_path_string_round_trips(tmp_path):
    _save(tmp_path, "model")
    assert isinstance(load_model(str(tmp_path / "model"), [CODEC]), Toy)


def _tampered(tmp_path, name, structure, **arrays):
    base = {"params/weights": np.zeros((3, 4)), "params/log_probs": np.log(np.full(3, 1 / 3)),
            "params/nested/counts": np.arange(3)}
    return save_arrays(tmp_path / name, "tests.Toy", {**base, **arrays}, {"structure": structure})


GOOD = {"inner": {"n": 3, "shape": [2, 2]}, "label": "x", "optional": None}


@pytest.mark.parametrize("name, structure, arrays, match", [
    ("nan", GOOD, {"params/weights": np.full((3, 4), np.nan)}, "NaN"),
    ("plus_inf", GOOD, {"params/log_probs": np.array([0.0, np.inf, 0.0])}, "NaN or \\+inf"),
    ("rows", GOOD, {"params/weights": np.zeros((2, 4))}, "expected shape"),
    ("named_size", GOOD, {"params/weights": np.zeros((3, 4, 1))}, "dimensions"),
    ("structure_disagrees", {**GOOD, "inner": {"n": 5}}, {}, "expected shape"),
    ("missing", GOOD, {"params/extra": np.zeros(2)}, "unexpected \\['params/extra'\\]"),
    ("int_as_float", GOOD, {"params/nested/counts": np.zeros(3)}, "expected integers"),
    ("overflow", GOOD, {"params/weights": np.full((3, 4), 1e300)}, "overflow float32"),
    ("unknown_field", {**GOOD, "n_iter": 5}, {}, "unknown field"),
    ("invalid_structure", {**GOOD, "inner": {"n": 0}}, {}, "n: must be >= 1"),
    ("semantic", GOOD, {"params/log_probs": np.zeros(3)}, "do not sum to 1"),
])
def test_files_that_disagree_with_their_structure_are_rejected(tmp_path, name, structure, arrays, match):
    path = _tampered(tmp_path, name, structure, **arrays)
    with pytest.raises(ValueError, match=match) as err:
        load_model(path, [CODEC])
    assert str(err.value).startswith(f"path: {path}")


def test_save_checks_the_model_and_its_type(tmp_path):
    with pytest.raises(ValueError, match="model: expected one of \\['Toy'\\]"):
        save_model(tmp_path / "x", object(), [CODEC])
    model, outer = _toy()
    bad = model._replace(params=model.params._replace(weights=model.params.weights[:2]))
    codec = dataclasses.replace(CODEC, structure_of=lambda m: outer)
    with pytest.raises(ValueError, match="^model array 'params/weights'"):
        save_model(tmp_path / "x", bad, [codec])
