"""Training with optax: L-BFGS (`optax.lbfgs`, zoom line search) or Adam, the whole loop in one jit.

`minimize(objective, params, data, ...)` runs `lax.while_loop` until one of CRFsuite's stopping
rules holds (so run times can be compared with it one to one):

* gradient: ||g|| / max(1, ||params||) < gtol,
* objective: (f_{k-period} - f_k) / |f_k| < delta (improvement over the last `period` iterations),
* `max_iter` iterations,
* early stopping: with `val_data`, the validation objective is evaluated every `eval_every`
  iterations and the loop stops after `patience` evaluations without improvement; the best
  parameters seen are returned.

Objectives follow CRFsuite's convention: sum over sequences of the negative log-likelihood plus
`l2 * ||theta||^2` (CRFsuite's `c2`), so the same `l2` means the same optimum in both.
Padded batches are handled by the models' masks (lengths), so a batch is one jitted call.
"""
from __future__ import annotations

from functools import partial
from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax
from jax import lax

Array = jax.Array


class TrainInfo(NamedTuple):
    """What `minimize` did. Histories have one slot per iteration; unused slots are NaN."""

    n_iter: Array  # () iterations run
    converged: Array  # () bool: a tolerance stopped the loop (or a step gave a non-finite objective)
    early_stopped: Array  # () bool: validation patience ran out
    loss: Array  # (max_iter,) training objective after each iteration
    val_loss: Array  # (max_iter,) validation objective where evaluated
    best_iter: Array  # () iteration whose parameters were returned


def l2_penalty(params: Any) -> Array:
    """sum of squares of every leaf of a parameter pytree."""
    return sum(jnp.sum(jnp.square(leaf)) for leaf in jax.tree_util.tree_leaves(params))


def _tree_norm(tree: Any) -> Array:
    return jnp.sqrt(l2_penalty(tree))


def make_optimizer(method: str, learning_rate: float, memory_size: int) -> optax.GradientTransformation:
    if method == "lbfgs":
        return optax.lbfgs(memory_size=memory_size)
    if method == "adam":
        return optax.adam(learning_rate)
    raise ValueError(f"method: expected 'lbfgs' or 'adam', got {method!r}")


@partial(
    jax.jit,
    static_argnames=("objective", "method", "max_iter", "learning_rate", "memory_size", "gtol", "delta",
                     "period", "patience", "eval_every", "val_objective"),
)
def minimize(
    objective: Callable[[Any, Any], Array],
    params: Any,
    data: Any,
    val_data: Any = None,
    *,
    method: str = "lbfgs",
    max_iter: int = 200,
    learning_rate: float = 1e-2,
    memory_size: int = 10,
    gtol: float = 1e-5,
    delta: float = 1e-5,
    period: int = 10,
    patience: int = 5,
    eval_every: int = 1,
    val_objective: Callable[[Any, Any], Array] | None = None,
) -> tuple[Any, TrainInfo]:
    """Minimise `objective(params, data)` (a scalar) from `params`; returns (params, TrainInfo).

    `objective` and `val_objective` must be hashable (module-level functions or `functools.partial`
    of them with hashable arguments); `data` / `val_data` are pytrees of arrays passed to them.
    `val_objective` defaults to `objective`.
    """
    opt = make_optimizer(method, learning_rate, memory_size)
    fun = lambda p: objective(p, data)  # noqa: E731
    vfun = None
    if val_data is not None:
        vobj = val_objective or objective
        vfun = lambda p: vobj(p, val_data)  # noqa: E731
    if method == "lbfgs":
        vg_state = optax.value_and_grad_from_state(fun)
    value0, grad0 = jax.value_and_grad(fun)(params)
    nan_hist = jnp.full((max_iter,), jnp.nan, jnp.float32)
    big = jnp.asarray(jnp.inf, jnp.float32)

    carry0 = dict(
        params=params, state=opt.init(params), value=value0, grad=grad0, k=jnp.int32(0),
        loss=nan_hist, val=nan_hist, best_params=params, best_val=big, best_iter=jnp.int32(0),
        bad=jnp.int32(0), converged=jnp.bool_(False), early=jnp.bool_(False),
    )

    def cond(c):
        return (c["k"] < max_iter) & ~c["converged"] & ~c["early"]

    def body(c):
        updates, state = opt.update(c["grad"], c["state"], c["params"], value=c["value"], grad=c["grad"],
                                    value_fn=fun)
        params = optax.apply_updates(c["params"], updates)
        if method == "lbfgs":
            value, grad = vg_state(params, state=state)
        else:
            value, grad = jax.value_and_grad(fun)(params)
        k = c["k"]
        # a non-finite objective (an overflowing step) is never accepted: keep the last good point
        ok = jnp.isfinite(value)
        params = jax.tree_util.tree_map(lambda n, o: jnp.where(ok, n, o), params, c["params"])
        value = jnp.where(ok, value, c["value"])
        grad = jax.tree_util.tree_map(lambda n, o: jnp.where(ok, n, o), grad, c["grad"])
        loss = c["loss"].at[k].set(value.astype(jnp.float32))
        gnorm = _tree_norm(grad) / jnp.maximum(1.0, _tree_norm(params))
        past = jnp.where(k + 1 > period, loss[jnp.maximum(k - period, 0)], jnp.inf)  # f_{k+1-period}
        rel = (past - value) / jnp.maximum(jnp.abs(value), 1e-30)
        converged = (gnorm < gtol) | (rel < delta) | ~ok
        out = dict(c, params=params, state=state, value=value, grad=grad, k=k + 1, loss=loss,
                   converged=converged)
        if vfun is None:
            return dict(out, best_params=params, best_iter=k + 1)

        def evaluate(o):
            v = vfun(o["params"]).astype(jnp.float32)
            better = v < o["best_val"]
            pick = lambda new, old: jnp.where(better, new, old)  # noqa: E731
            return dict(
                o, val=o["val"].at[k].set(v),
                best_params=jax.tree_util.tree_map(pick, o["params"], o["best_params"]),
                best_val=jnp.minimum(v, o["best_val"]), best_iter=jnp.where(better, k + 1, o["best_iter"]),
                bad=jnp.where(better, 0, o["bad"] + 1), early=(o["bad"] + 1 >= patience) & ~better,
            )

        return lax.cond((k + 1) % eval_every == 0, evaluate, lambda o: o, out)

    c = lax.while_loop(cond, body, carry0)
    never = ~jnp.isfinite(c["best_val"]) if vfun is not None else jnp.bool_(False)  # no evaluation ran
    best = jax.tree_util.tree_map(lambda f, b: jnp.where(never, f, b), c["params"], c["best_params"])
    best_iter = jnp.where(never, c["k"], c["best_iter"])
    info = TrainInfo(c["k"], c["converged"], c["early"], c["loss"], c["val"], best_iter)
    return best, info


# ----------------------------------------------------------------------------------------------
# objectives (module-level, so `minimize` compiles once per shape); data = (..., l2)
# ----------------------------------------------------------------------------------------------
def chain_objective(model, data) -> Array:
    """sum_b NLL_b + l2 ||theta||^2 for a ChainCRF; data = (X (B,T,D), y (B,T), lengths (B,), l2 ())."""
    from crf_jax.chain import nll

    X, y, lengths, l2 = data
    return jnp.sum(nll(model, X, y, lengths)) + l2 * l2_penalty(model)


def _fit_kwargs(method, max_iter, learning_rate, memory_size, gtol, delta, period, patience, eval_every):
    from lfd_common import check_choice, check_int, check_real

    return dict(
        method=check_choice(method, "method", ("lbfgs", "adam")),
        max_iter=check_int(max_iter, "max_iter", min_value=1),
        learning_rate=check_real(learning_rate, "learning_rate", min_value=0.0, exclusive_min=True),
        memory_size=check_int(memory_size, "memory_size", min_value=1),
        gtol=check_real(gtol, "gtol", min_value=0.0),
        delta=check_real(delta, "delta", min_value=0.0),
        period=check_int(period, "period", min_value=1),
        patience=check_int(patience, "patience", min_value=1),
        eval_every=check_int(eval_every, "eval_every", min_value=1),
    )


def fit_chain(
    X, y, lengths=None, *, n_labels: int | None = None, connectivity: int = 0, l2: float = 1.0,
    validation: tuple | None = None, init=None, method: str = "lbfgs", max_iter: int = 200,
    learning_rate: float = 0.05, memory_size: int = 10, gtol: float = 1e-5, delta: float = 1e-5,
    period: int = 10, patience: int = 5, eval_every: int = 1,
):
    """Fit a linear-chain CRF to per-frame labels. Returns (ChainCRF, TrainInfo).

    X (B, T, D) padded features, y (B, T) labels in [0, n_labels), lengths (B,) or None.
    n_labels defaults to max(y) + 1. connectivity C: each label sees x_{t-C..t+C}.
    l2: CRFsuite's c2 (objective = sum NLL + l2 ||theta||^2). validation: (X_val, y_val[, lengths_val])
    for early stopping. init: a ChainCRF to start from (default zeros: the objective is convex).
    """
    from crf_jax._checks import check_batch, check_labels
    from crf_jax.chain import ChainCRF, init_chain
    from lfd_common import check_int, check_real

    kw = _fit_kwargs(method, max_iter, learning_rate, memory_size, gtol, delta, period, patience, eval_every)
    connectivity = check_int(connectivity, "connectivity", min_value=0)
    l2 = check_real(l2, "l2", min_value=0.0)
    Xc, lens = check_batch(X, lengths)
    if n_labels is None:
        yc0 = check_labels(y, lens, np.iinfo(np.int32).max)
        n_labels = int(yc0.max()) + 1
    n_labels = check_int(n_labels, "n_labels", min_value=1)
    yc = check_labels(y, lens, n_labels)[:, : Xc.shape[1]]
    data = (jnp.asarray(Xc), jnp.asarray(yc), jnp.asarray(lens), jnp.float32(l2))
    val_data = None
    if validation is not None:
        if not isinstance(validation, (tuple, list)) or len(validation) not in (2, 3):
            raise ValueError("validation: expected (X_val, y_val) or (X_val, y_val, lengths_val)")
        Xv, lv = check_batch(validation[0], validation[2] if len(validation) == 3 else None,
                             n_features=Xc.shape[2], name="validation[0]", lengths_name="validation[2]")
        yv = check_labels(validation[1], lv, n_labels, name="validation[1]")[:, : Xv.shape[1]]
        # validation objective: the NLL alone (no penalty), as a held-out criterion
        val_data = (jnp.asarray(Xv), jnp.asarray(yv), jnp.asarray(lv), jnp.float32(0.0))
    if init is None:
        params = init_chain(Xc.shape[2], n_labels, connectivity)
    else:
        if not isinstance(init, ChainCRF):
            raise ValueError(f"init: expected a ChainCRF, got {type(init).__name__}")
        if (init.connectivity, init.n_features, init.n_labels) != (connectivity, Xc.shape[2], n_labels):
            raise ValueError("init: its connectivity, feature and label counts must match the data and arguments")
        params = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float32), init)
    return minimize(chain_objective, params, data, val_data, **kw)


def hcrf_objective(model, data) -> Array:
    """sum_b -log P(y_b | x_b) + l2 ||theta||^2 for an HCRF; data = (X, y (B,), lengths, l2)."""
    from crf_jax.hcrf import nll

    X, y, lengths, l2 = data
    return jnp.sum(nll(model, X, y, lengths)) + l2 * l2_penalty(model)


def fcrf_objective_exact(model, data) -> Array:
    """FCRF sum NLL (exact product-space log Z) + l2 penalty; data = (X, ya, yo, lengths, l2)."""
    from crf_jax.fcrf import nll

    X, ya, yo, lengths, l2 = data
    return jnp.sum(nll(model, X, ya, yo, lengths, method="exact")) + l2 * l2_penalty(model)


def fcrf_objective_loopy(model, data) -> Array:
    """FCRF sum NLL with the Bethe log Z of 20 rounds of loopy BP + l2 penalty."""
    from crf_jax.fcrf import nll

    X, ya, yo, lengths, l2 = data
    return jnp.sum(nll(model, X, ya, yo, lengths, method="loopy", n_iter=20)) + l2 * l2_penalty(model)


def logistic_objective(model, data) -> Array:
    from crf_jax.linear import logistic_loss

    X, y, l2 = data
    return jnp.sum(logistic_loss(model, X, y)) + l2 * jnp.sum(jnp.square(model.weights))


def svm_objective(model, data) -> Array:
    from crf_jax.linear import hinge_loss

    X, y, l2 = data
    return jnp.sum(hinge_loss(model, X, y)) + l2 * jnp.sum(jnp.square(model.weights))


def _split_validation(validation, n_parts: int, name: str = "validation"):
    if not isinstance(validation, (tuple, list)) or len(validation) not in (n_parts, n_parts + 1):
        raise ValueError(f"{name}: expected a tuple of {n_parts} arrays (+ optional lengths)")
    return validation[:n_parts], (validation[n_parts] if len(validation) == n_parts + 1 else None)


def fit_hcrf(
    X, y, lengths=None, *, n_labels: int | None = None, n_hidden: int = 3, connectivity: int = 0,
    l2: float = 1.0, seed: int = 0, validation: tuple | None = None, method: str = "lbfgs",
    max_iter: int = 200, learning_rate: float = 0.05, memory_size: int = 10, gtol: float = 1e-5,
    delta: float = 1e-5, period: int = 10, patience: int = 5, eval_every: int = 1,
):
    """Fit a hidden CRF to one class label per sequence: X (B, T, D), y (B,). Returns (HCRF, TrainInfo).

    Non-convex: `seed` sets the random start. validation: (X_val, y_val[, lengths_val]).
    """
    from crf_jax._checks import check_batch, check_class_labels
    from crf_jax.hcrf import init_hcrf
    from lfd_common import check_int, check_real

    kw = _fit_kwargs(method, max_iter, learning_rate, memory_size, gtol, delta, period, patience, eval_every)
    n_hidden = check_int(n_hidden, "n_hidden", min_value=1)
    connectivity = check_int(connectivity, "connectivity", min_value=0)
    l2 = check_real(l2, "l2", min_value=0.0)
    seed = check_int(seed, "seed")
    Xc, lens = check_batch(X, lengths)
    if n_labels is None:
        n_labels = int(check_class_labels(y, Xc.shape[0], np.iinfo(np.int32).max).max()) + 1
    n_labels = check_int(n_labels, "n_labels", min_value=1)
    yc = check_class_labels(y, Xc.shape[0], n_labels)
    data = (jnp.asarray(Xc), jnp.asarray(yc), jnp.asarray(lens), jnp.float32(l2))
    val_data = None
    if validation is not None:
        (Xv, yv), lv = _split_validation(validation, 2)
        Xv, lv = check_batch(Xv, lv, n_features=Xc.shape[2], name="validation[0]", lengths_name="validation[2]")
        yv = check_class_labels(yv, Xv.shape[0], n_labels, name="validation[1]")
        val_data = (jnp.asarray(Xv), jnp.asarray(yv), jnp.asarray(lv), jnp.float32(0.0))
    params = init_hcrf(jax.random.PRNGKey(seed), Xc.shape[2], n_labels, n_hidden, connectivity)
    return minimize(hcrf_objective, params, data, val_data, **kw)


def fit_fcrf(
    X, y_action, y_object, lengths=None, *, n_actions: int | None = None, n_objects: int | None = None,
    connectivity: int = 0, l2: float = 1.0, inference: str = "exact", validation: tuple | None = None,
    method: str = "lbfgs", max_iter: int = 200, learning_rate: float = 0.05, memory_size: int = 10,
    gtol: float = 1e-5, delta: float = 1e-5, period: int = 10, patience: int = 5, eval_every: int = 1,
):
    """Fit a factorial CRF to per-frame action and object labels y_action, y_object (B, T).

    inference: "exact" (product space) or "loopy" (Bethe log Z from loopy BP, as in the paper).
    validation: (X_val, ya_val, yo_val[, lengths_val]). Returns (FCRF, TrainInfo).
    """
    from crf_jax._checks import check_batch, check_labels
    from crf_jax.fcrf import init_fcrf
    from lfd_common import check_choice, check_int, check_real

    kw = _fit_kwargs(method, max_iter, learning_rate, memory_size, gtol, delta, period, patience, eval_every)
    inference = check_choice(inference, "inference", ("exact", "loopy"))
    connectivity = check_int(connectivity, "connectivity", min_value=0)
    l2 = check_real(l2, "l2", min_value=0.0)
    Xc, lens = check_batch(X, lengths)
    big = np.iinfo(np.int32).max
    n_actions = int(check_labels(y_action, lens, big, "y_action").max()) + 1 if n_actions is None else n_actions
    n_objects = int(check_labels(y_object, lens, big, "y_object").max()) + 1 if n_objects is None else n_objects
    n_actions = check_int(n_actions, "n_actions", min_value=1)
    n_objects = check_int(n_objects, "n_objects", min_value=1)
    T = Xc.shape[1]
    ya = check_labels(y_action, lens, n_actions, "y_action")[:, :T]
    yo = check_labels(y_object, lens, n_objects, "y_object")[:, :T]
    objective = fcrf_objective_exact if inference == "exact" else fcrf_objective_loopy
    data = (jnp.asarray(Xc), jnp.asarray(ya), jnp.asarray(yo), jnp.asarray(lens), jnp.float32(l2))
    val_data = None
    if validation is not None:
        (Xv, yav, yov), lv = _split_validation(validation, 3)
        Xv, lv = check_batch(Xv, lv, n_features=Xc.shape[2], name="validation[0]", lengths_name="validation[3]")
        yav = check_labels(yav, lv, n_actions, "validation[1]")[:, : Xv.shape[1]]
        yov = check_labels(yov, lv, n_objects, "validation[2]")[:, : Xv.shape[1]]
        val_data = (jnp.asarray(Xv), jnp.asarray(yav), jnp.asarray(yov), jnp.asarray(lv), jnp.float32(0.0))
    params = init_fcrf(Xc.shape[2], n_actions, n_objects, connectivity)
    return minimize(objective, params, data, val_data, **kw)


def fit_linear(
    X, y, *, kind: str = "logistic", n_labels: int | None = None, l2: float = 1.0,
    validation: tuple | None = None, method: str | None = None, max_iter: int = 500,
    learning_rate: float = 0.01, memory_size: int = 10, gtol: float = 1e-5, delta: float = 1e-6,
    period: int = 10, patience: int = 10, eval_every: int = 1,
):
    """Fit a per-vector baseline to X (N, D), y (N,): kind "logistic" or "svm" (multiclass hinge).

    method defaults to L-BFGS for the smooth logistic loss and Adam for the non-smooth hinge.
    Returns (LinearModel, TrainInfo).
    """
    from crf_jax._checks import check_class_labels
    from crf_jax.linear import init_linear
    from lfd_common import as_array, check_choice, check_int, check_real

    kind = check_choice(kind, "kind", ("logistic", "svm"))
    if method is None:
        method = "lbfgs" if kind == "logistic" else "adam"
    kw = _fit_kwargs(method, max_iter, learning_rate, memory_size, gtol, delta, period, patience, eval_every)
    l2 = check_real(l2, "l2", min_value=0.0)
    Xc = as_array(X, "X", ndim=2).astype(np.float32)
    if n_labels is None:
        n_labels = int(check_class_labels(y, Xc.shape[0], np.iinfo(np.int32).max).max()) + 1
    n_labels = check_int(n_labels, "n_labels", min_value=1)
    yc = check_class_labels(y, Xc.shape[0], n_labels)
    objective = logistic_objective if kind == "logistic" else svm_objective
    val_data = None
    if validation is not None:
        (Xv, yv), _ = _split_validation(validation, 2)
        Xv = as_array(Xv, "validation[0]", shape=(None, Xc.shape[1])).astype(np.float32)
        yv = check_class_labels(yv, Xv.shape[0], n_labels, name="validation[1]")
        val_data = (jnp.asarray(Xv), jnp.asarray(yv), jnp.float32(0.0))
    params = init_linear(Xc.shape[1], n_labels)
    return minimize(objective, params, (jnp.asarray(Xc), jnp.asarray(yc), jnp.float32(l2)), val_data, **kw)
