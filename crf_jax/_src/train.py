"""Fitting the crf_jax models: their objectives and the validated `fit_*` functions.

Objectives follow CRFsuite's convention: sum over sequences (or vectors) of the negative
log-likelihood (or hinge loss) plus `l2 * ||theta||^2` (CRFsuite's `c2`), so the same `l2` means the
same optimum in both. `l2` is part of the objective, not of the search: it is a fit argument (traced,
passed in the objective's data), while how the optimum is searched for is one `FitOptions`
(`solver`) shared by every `fit_*`. Model-defining arguments (label counts, connectivity,
hidden states, the FCRF's inference) are fit arguments too; validation data, when given, is scored
without the penalty (the NLL alone, a held-out criterion) for early stopping.

Every `fit_*` returns `FitResult(model, info)`. Padded batches are handled by the models' masks
(lengths), so a batch is one jitted call. A fit never reports a non-finite objective as converged:
if the objective (or its gradient) is already non-finite at the starting parameters (features whose
products overflow float32), the fit raises `ValueError` naming `X`; if it becomes non-finite later,
the last finite parameters are returned with `info.diverged` set and a `RuntimeWarning`.
"""
from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh
from jaxtyping import Array, ArrayLike, Float, Int

from crf_jax._src import chain as chain, fcrf as fcrf, hcrf as hcrf, linear as linear
from crf_jax._src.checks import check_batch, check_class_labels, check_labels, check_vectors
from crf_jax._src.chain import ChainCRF, init_chain
from crf_jax._src.fcrf import init_fcrf
from crf_jax._src.hcrf import init_hcrf
from crf_jax._src.linear import init_linear
from crf_jax._src.solver import FitOptions, FitResult, TrainInfo, l2_penalty, minimize
from lfd_common import check_choice, check_int, check_real
from lfd_common import check_mesh, shard

_NO_LIMIT = np.iinfo(np.int32).max


# ----------------------------------------------------------------------------------------------
# objectives (module-level, so `minimize` compiles once per shape); data = (..., l2)
# ----------------------------------------------------------------------------------------------
def chain_objective(model, data) -> Array:
    """sum_b NLL_b + l2 ||theta||^2 for a ChainCRF; data = (X (B,T,D), y (B,T), lengths (B,), l2 ())."""
    X, y, lengths, l2 = data
    return jnp.sum(chain.nll(model, X, y, lengths)) + l2 * l2_penalty(model)


def masked_chain_objective(model, data) -> Array:
    """`chain_objective` over the sequences where mask (B,) is True, for a batch padded to a device
    mesh (`lfd_common.shard`); data = (X, y, lengths, mask, l2)."""
    X, y, lengths, mask, l2 = data
    return jnp.sum(jnp.where(mask, chain.nll(model, X, y, lengths), 0.0)) + l2 * l2_penalty(model)


def hcrf_objective(model, data) -> Array:
    """sum_b -log P(y_b | x_b) + l2 ||theta||^2 for an HCRF; data = (X, y (B,), lengths, l2)."""
    X, y, lengths, l2 = data
    return jnp.sum(hcrf.nll(model, X, y, lengths)) + l2 * l2_penalty(model)


def fcrf_objective_exact(model, data) -> Array:
    """FCRF sum NLL (exact product-space log Z) + l2 penalty; data = (X, ya, yo, lengths, l2)."""
    X, ya, yo, lengths, l2 = data
    return jnp.sum(fcrf.nll(model, X, ya, yo, lengths, method="exact")) + l2 * l2_penalty(model)


def fcrf_objective_loopy(model, data) -> Array:
    """FCRF sum NLL with the Bethe log Z of 20 rounds of loopy BP + l2 penalty."""
    X, ya, yo, lengths, l2 = data
    return jnp.sum(fcrf.nll(model, X, ya, yo, lengths, method="loopy", n_iter=20)) + l2 * l2_penalty(model)


def logistic_objective(model, data) -> Array:
    """sum_n -log softmax(s_n)_{y_n} + l2 ||weights||^2 (the bias is not penalised); data = (X, y, l2)."""
    X, y, l2 = data
    return jnp.sum(linear.logistic_loss(model, X, y)) + l2 * jnp.sum(jnp.square(model.weights))


def svm_objective(model, data) -> Array:
    """sum_n Crammer-Singer hinge + l2 ||weights||^2; data = (X, y, l2)."""
    X, y, l2 = data
    return jnp.sum(linear.hinge_loss(model, X, y)) + l2 * jnp.sum(jnp.square(model.weights))


# ----------------------------------------------------------------------------------------------
# argument checks shared by the fits
# ----------------------------------------------------------------------------------------------
def _options(options: FitOptions | None, default: FitOptions) -> FitOptions:
    if options is None:
        return default
    if not isinstance(options, FitOptions):
        raise ValueError(f"options: expected a crf_jax.FitOptions or None, got {type(options).__name__}")
    return options


def _label_count(n: int | None, y, check, name: str) -> int:
    """`n`, or max(y) + 1 when it is None; `check(y, n_labels)` validates the labels."""
    if n is None:
        n = int(check(y, _NO_LIMIT).max()) + 1
    return check_int(n, name, min_value=1)


def _split_validation(validation, n_parts: int, name: str = "validation"):
    """(arrays, lengths or None) of `validation` = (n_parts arrays[, lengths])."""
    if not isinstance(validation, (tuple, list)) or len(validation) not in (n_parts, n_parts + 1):
        raise ValueError(f"{name}: expected a tuple of {n_parts} arrays (+ optional lengths)")
    return validation[:n_parts], (validation[n_parts] if len(validation) == n_parts + 1 else None)


def _sequence_batches(X, lengths, validation, n_labelled: int):
    """Checked training and validation feature batches: (Xc, lens, Xv, lv, yv_raw) (None for no validation)."""
    Xc, lens = check_batch(X, lengths)
    if validation is None:
        return Xc, lens, None, None, None
    parts, lv = _split_validation(validation, n_labelled + 1)
    Xv, lv = check_batch(parts[0], lv, n_features=Xc.shape[2], name="validation[0]",
                         lengths_name=f"validation[{n_labelled + 1}]")
    return Xc, lens, Xv, lv, parts[1:]


def _frames(y, lens, n_labels: int, name: str, T: int) -> Array:
    """Per-frame labels (B, T) checked against lengths, cut to the feature batch's T, as a jax array."""
    return jnp.asarray(check_labels(y, lens, n_labels, name)[:, :T])


def _data(*arrays, l2: float) -> tuple:
    return (*(jnp.asarray(a) for a in arrays), jnp.float32(l2))


def _finish(result: FitResult, fit: str, name: str = "X") -> FitResult:
    """`result`, after checking that the search never met a non-finite objective (see the module doc)."""
    info = result.info
    if bool(info.diverged):
        if int(info.n_iter) == 0:
            raise ValueError(f"{name}: the {fit} objective or its gradient is not finite at the starting "
                             "parameters (NaN or inf in the compute dtype): the features are too large, "
                             "rescale them")
        warnings.warn(f"{fit}: the objective became non-finite at iteration {int(info.n_iter)}; returning the "
                      "last finite parameters (info.diverged is set, info.converged is not)",
                      RuntimeWarning, stacklevel=3)
    return result


# ----------------------------------------------------------------------------------------------
# the fits
# ----------------------------------------------------------------------------------------------
def fit_chain(
    X: Float[ArrayLike, "B T D"], y: Int[ArrayLike, "B T"], lengths: Int[ArrayLike, " B"] | None = None, *,
    n_labels: int | None = None, connectivity: int = 0, l2: float = 1.0, validation: tuple | None = None,
    init: ChainCRF | None = None, options: FitOptions | None = None, mesh: Mesh | None = None,
) -> FitResult:
    """Fit a linear-chain CRF to per-frame labels (OAC eqs. 3-4, LfD eqs. 7-8).

    Objective: sum over sequences of the negative log-likelihood plus l2 ||theta||^2 (CRFsuite's
    c2 convention), convex.

    Args:
        X: (B, T, D) padded features.
        y: (B, T) labels in [0, n_labels) on the real frames.
        lengths: (B,) frames per sequence in [1, T], or None (all T).
        n_labels: K; None: max(y) + 1.
        connectivity: C >= 0: each label sees x_{t-C..t+C}.
        l2: CRFsuite's c2, >= 0 (objective = sum NLL + l2 ||theta||^2).
        validation: (X_val, y_val[, lengths_val]) for early stopping, scored by the NLL alone.
        init: A ChainCRF to start from (default zeros: the objective is convex).
        options: The search (default `FitOptions()`).
        mesh: A `jax.sharding.Mesh` (or None: one device). The training sequences are split over
            its devices (padded to the mesh, padding masked out of the objective) and the one jitted
            search runs data-parallel: each device's NLL and gradient cover its sequences and XLA
            sums them over the mesh. The fit equals the one-device fit to round-off. With several
            processes each passes its own sequences.

    Returns:
        `FitResult(ChainCRF, TrainInfo)`.

    Raises:
        ValueError: Naming the argument: shapes, NaN/inf features, labels out of range or
            non-integral, counts or l2 out of range, a malformed `validation`, an `init` that does
            not match the data or is not finite, `options` not a FitOptions, `mesh` not a Mesh;
            naming `X` when the objective is not finite at the start (features too large for
            float32).
    Warns:
        RuntimeWarning: The objective became non-finite after the start: the last finite
            parameters come back with `info.diverged` set.
    """
    options = _options(options, FitOptions())
    mesh = check_mesh(mesh)
    connectivity = check_int(connectivity, "connectivity", min_value=0)
    l2 = check_real(l2, "l2", min_value=0.0)
    Xc, lens, Xv, lv, yv = _sequence_batches(X, lengths, validation, 1)
    n_labels = _label_count(n_labels, y, lambda y_, n: check_labels(y_, lens, n), "n_labels")
    data = _data(Xc, _frames(y, lens, n_labels, "y", Xc.shape[1]), lens, l2=l2)
    objective = chain_objective
    if mesh is not None:
        batch = shard(mesh, *data[:3])
        objective, data = masked_chain_objective, (*batch.arrays, batch.mask, data[3])
    val_data = None if Xv is None else _data(Xv, _frames(yv[0], lv, n_labels, "validation[1]", Xv.shape[1]), lv,
                                             l2=0.0)
    if init is None:
        params = init_chain(Xc.shape[2], n_labels, connectivity)
    else:
        if not isinstance(init, ChainCRF):
            raise ValueError(f"init: expected a ChainCRF, got {type(init).__name__}")
        if (init.connectivity, init.n_features, init.n_labels) != (connectivity, Xc.shape[2], n_labels):
            raise ValueError("init: its connectivity, feature and label counts must match the data and arguments")
        params = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float32), init)
        if not all(bool(jnp.all(jnp.isfinite(leaf))) for leaf in params):
            raise ValueError("init: contains NaN or infinite values (or values overflowing float32)")
    return _finish(minimize(objective, params, data, val_data, options), "fit_chain")


def fit_hcrf(
    X: Float[ArrayLike, "B T D"], y: Int[ArrayLike, " B"], lengths: Int[ArrayLike, " B"] | None = None, *,
    n_labels: int | None = None, n_hidden: int = 3, connectivity: int = 0, l2: float = 1.0, seed: int = 0,
    validation: tuple | None = None, options: FitOptions | None = None,
) -> FitResult:
    """Fit a hidden CRF to one class label per pre-segmented sequence (OAC eqs. 5-6).

    Non-convex (hidden states): `seed` sets the random start.

    Args:
        X: (B, T, D) padded features.
        y: (B,) class labels in [0, n_labels).
        lengths: (B,) frames per sequence in [1, T], or None (all T).
        n_labels: K; None: max(y) + 1.
        n_hidden: H, hidden states per class, >= 1.
        connectivity: C >= 0: each hidden state sees x_{t-C..t+C}.
        l2: CRFsuite's c2, >= 0 (objective = sum NLL + l2 ||theta||^2).
        seed: Integer seed of the random start.
        validation: (X_val, y_val[, lengths_val]) for early stopping.
        options: The search (default `FitOptions()`).

    Returns:
        `FitResult(HCRF, TrainInfo)`.

    Raises:
        ValueError: Naming the argument, as `fit_chain` does.
    Warns:
        RuntimeWarning: The objective became non-finite after the start: the last finite
            parameters come back with `info.diverged` set.
    """
    options = _options(options, FitOptions())
    n_hidden = check_int(n_hidden, "n_hidden", min_value=1)
    connectivity = check_int(connectivity, "connectivity", min_value=0)
    l2 = check_real(l2, "l2", min_value=0.0)
    seed = check_int(seed, "seed")
    Xc, lens, Xv, lv, yv = _sequence_batches(X, lengths, validation, 1)
    n_labels = _label_count(n_labels, y, lambda y_, n: check_class_labels(y_, Xc.shape[0], n), "n_labels")
    data = _data(Xc, check_class_labels(y, Xc.shape[0], n_labels), lens, l2=l2)
    val_data = None if Xv is None else _data(
        Xv, check_class_labels(yv[0], Xv.shape[0], n_labels, name="validation[1]"), lv, l2=0.0)
    params = init_hcrf(jax.random.PRNGKey(seed), Xc.shape[2], n_labels, n_hidden, connectivity)
    return _finish(minimize(hcrf_objective, params, data, val_data, options), "fit_hcrf")


def fit_fcrf(
    X: Float[ArrayLike, "B T D"], y_action: Int[ArrayLike, "B T"], y_object: Int[ArrayLike, "B T"],
    lengths: Int[ArrayLike, " B"] | None = None, *, n_actions: int | None = None, n_objects: int | None = None,
    connectivity: int = 0, l2: float = 1.0, inference: str = "exact", validation: tuple | None = None,
    options: FitOptions | None = None,
) -> FitResult:
    """Fit a factorial CRF to per-frame action and object labels (OAC eq. 7, "early fusion").

    Args:
        X: (B, T, D) padded features (the action and object features concatenated).
        y_action: (B, T) action labels in [0, n_actions) on the real frames.
        y_object: (B, T) object labels in [0, n_objects) on the real frames.
        lengths: (B,) frames per sequence in [1, T], or None (all T).
        n_actions: Ka; None: max(y_action) + 1.
        n_objects: Ko; None: max(y_object) + 1.
        connectivity: C >= 0, for both chains.
        l2: CRFsuite's c2, >= 0 (objective = sum NLL + l2 ||theta||^2).
        inference: "exact" (product space) or "loopy" (Bethe log Z from loopy BP, as in the
            paper); it defines the objective, so it is a fit argument.
        validation: (X_val, ya_val, yo_val[, lengths_val]) for early stopping.
        options: The search (default `FitOptions()`).

    Returns:
        `FitResult(FCRF, TrainInfo)`.

    Raises:
        ValueError: Naming the argument, as `fit_chain` does, and `inference` when it is neither.
    Warns:
        RuntimeWarning: The objective became non-finite after the start: the last finite
            parameters come back with `info.diverged` set.
    """
    options = _options(options, FitOptions())
    inference = check_choice(inference, "inference", ("exact", "loopy"))
    connectivity = check_int(connectivity, "connectivity", min_value=0)
    l2 = check_real(l2, "l2", min_value=0.0)
    Xc, lens, Xv, lv, yv = _sequence_batches(X, lengths, validation, 2)
    n_actions = _label_count(n_actions, y_action, lambda y_, n: check_labels(y_, lens, n, "y_action"), "n_actions")
    n_objects = _label_count(n_objects, y_object, lambda y_, n: check_labels(y_, lens, n, "y_object"), "n_objects")
    T = Xc.shape[1]
    data = _data(Xc, _frames(y_action, lens, n_actions, "y_action", T),
                 _frames(y_object, lens, n_objects, "y_object", T), lens, l2=l2)
    val_data = None if Xv is None else _data(
        Xv, _frames(yv[0], lv, n_actions, "validation[1]", Xv.shape[1]),
        _frames(yv[1], lv, n_objects, "validation[2]", Xv.shape[1]), lv, l2=0.0)
    objective = fcrf_objective_exact if inference == "exact" else fcrf_objective_loopy
    params = init_fcrf(Xc.shape[2], n_actions, n_objects, connectivity)
    return _finish(minimize(objective, params, data, val_data, options), "fit_fcrf")


def fit_linear(
    X: Float[ArrayLike, "N D"], y: Int[ArrayLike, " N"], *, kind: str = "logistic", n_labels: int | None = None,
    l2: float = 1.0, validation: tuple | None = None, options: FitOptions | None = None,
) -> FitResult:
    """Fit a per-vector baseline: multinomial logistic regression or a linear SVM (OAC §5).

    Objective: sum over the N examples of -log softmax(s)_y ("logistic") or the Crammer-Singer
    multiclass hinge ("svm"), plus l2 ||weights||^2 (the bias is not penalised).

    Args:
        X: (N, D) feature vectors.
        y: (N,) class labels in [0, n_labels).
        kind: "logistic" or "svm".
        n_labels: K; None: max(y) + 1.
        l2: The weights' penalty, >= 0.
        validation: (X_val, y_val) for early stopping.
        options: The search; None: `FitOptions.for_linear(kind)` (L-BFGS for the smooth logistic
            loss and Adam for the non-smooth hinge, 500 iterations).

    Returns:
        `FitResult(LinearModel, TrainInfo)`.

    Raises:
        ValueError: Naming the argument, as `fit_chain` does, and `kind` when it is neither.
    Warns:
        RuntimeWarning: The objective became non-finite after the start: the last finite
            parameters come back with `info.diverged` set.
    """
    kind = check_choice(kind, "kind", ("logistic", "svm"))
    options = _options(options, FitOptions.for_linear(kind))
    l2 = check_real(l2, "l2", min_value=0.0)
    Xc = check_vectors(X)
    n_labels = _label_count(n_labels, y, lambda y_, n: check_class_labels(y_, Xc.shape[0], n), "n_labels")
    data = _data(Xc, check_class_labels(y, Xc.shape[0], n_labels), l2=l2)
    val_data = None
    if validation is not None:
        (Xv, yv), _ = _split_validation(validation, 2)
        Xv = check_vectors(Xv, n_features=Xc.shape[1], name="validation[0]")
        val_data = _data(Xv, check_class_labels(yv, Xv.shape[0], n_labels, name="validation[1]"), l2=0.0)
    objective = logistic_objective if kind == "logistic" else svm_objective
    return _finish(minimize(objective, init_linear(Xc.shape[1], n_labels), data, val_data, options), "fit_linear")


__all__ = [
    "FitOptions", "FitResult", "TrainInfo", "chain_objective", "fcrf_objective_exact", "fcrf_objective_loopy",
    "fit_chain", "fit_fcrf", "fit_hcrf", "fit_linear", "hcrf_objective", "l2_penalty", "logistic_objective",
    "minimize", "svm_objective",
]
