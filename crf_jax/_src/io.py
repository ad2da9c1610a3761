"""Persistence of crf_jax models through `lfd_common`'s generic model files: `save(path, model)` /
`load(path)`.

A file holds the kind ("crf_jax.ChainCRF", "crf_jax.HCRF", "crf_jax.FCRF", "crf_jax.LinearModel"),
the model's structure (`ChainStructure`, `HCRFStructure`, `FCRFStructure`, `LinearStructure`) as
JSON and one array per parameter leaf ("weights", "action/trans", ...). `load` reads the kind from
the file, rebuilds the structure and checks every array against the shapes it implies (and that it
is finite), so a truncated, corrupt, tampered or unknown file is a `ValueError` naming the file.
"""
from __future__ import annotations

from pathlib import Path

from crf_jax._src.chain import ChainCRF, ChainStructure
from crf_jax._src.fcrf import FCRF, FCRFStructure
from crf_jax._src.hcrf import HCRF, HCRFStructure
from crf_jax._src.linear import LinearModel, LinearStructure
from lfd_common import ArraySpec, ModelCodec, load_model, save_model


def _chain_template(s: ChainStructure) -> ChainCRF:
    K = s.n_labels
    return ChainCRF(ArraySpec((2 * s.connectivity + 1, s.n_features, K)), ArraySpec((K,)), ArraySpec((K, K)))


def _hcrf_template(s: HCRFStructure) -> HCRF:
    W, K, H = 2 * s.connectivity + 1, s.n_labels, s.n_hidden
    return HCRF(ArraySpec((W, s.n_features, K, H)), ArraySpec((K, H)), ArraySpec((K, H, H)))


def _fcrf_template(s: FCRFStructure) -> FCRF:
    action, objects = (_chain_template(ChainStructure(n, s.n_features, s.connectivity))
                       for n in (s.n_actions, s.n_objects))
    return FCRF(action, objects, ArraySpec((s.n_actions, s.n_objects)))


def _linear_template(s: LinearStructure) -> LinearModel:
    return LinearModel(ArraySpec((s.n_features, s.n_labels)), ArraySpec((s.n_labels,)))


def _structure(model):
    return model.structure


CODECS = (
    ModelCodec("crf_jax.ChainCRF", ChainCRF, ChainStructure, _structure, _chain_template),
    ModelCodec("crf_jax.HCRF", HCRF, HCRFStructure, _structure, _hcrf_template),
    ModelCodec("crf_jax.FCRF", FCRF, FCRFStructure, _structure, _fcrf_template),
    ModelCodec("crf_jax.LinearModel", LinearModel, LinearStructure, _structure, _linear_template),
)


def save(path: str | Path, model: ChainCRF | HCRF | FCRF | LinearModel) -> Path:
    """Write a crf_jax model to a model file (kind, structure as JSON, one array per leaf).

    The model is checked as `load` checks it, so what `save` writes always loads.

    Args:
        path: The file; ".npz" is appended when absent.
        model: A `ChainCRF`, `HCRF`, `FCRF` or `LinearModel`.

    Returns:
        The path of the file written.

    Raises:
        ValueError: Naming `model` when it is none of those types or has non-finite arrays, or
            naming `path` when it is not a path.
    """
    return save_model(path, model, CODECS)


def load(path: str | Path, model_type: type | None = None) -> ChainCRF | HCRF | FCRF | LinearModel:
    """Read a model written by `save`; its type comes from the file.

    Args:
        path: The file (".npz" appended when absent, as `save` does).
        model_type: Optionally the class the caller expects.

    Returns:
        The stored `ChainCRF`, `HCRF`, `FCRF` or `LinearModel`.

    Raises:
        FileNotFoundError: The file does not exist.
        ValueError: Naming the file, for a truncated, corrupt, tampered or unknown file, arrays
            that disagree with the stored structure, or another stored type than `model_type`.
    """
    model = load_model(path, CODECS)
    if model_type is not None and type(model) is not model_type:
        raise ValueError(f"path: {path} holds a {type(model).__name__}, expected a "
                         f"{getattr(model_type, '__name__', repr(model_type))}")
    return model
