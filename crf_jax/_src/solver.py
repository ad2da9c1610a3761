"""The solver every `fit_*` shares: optax L-BFGS (zoom line search), Adam or any optax optimiser, the
whole loop in one jit, configured by one `FitOptions`.

`minimize(objective, params, data, options=...)` runs `lax.while_loop` until one of CRFsuite's
stopping rules holds (so run times can be compared with it one to one):

* gradient: ||g|| / max(1, ||params||) < gtol,
* objective: (f_{k-period} - f_k) / |f_k| < delta (improvement over the last `period` iterations),
* `max_iter` iterations,
* early stopping: with `val_data`, the validation objective is evaluated every `eval_every`
  iterations and the loop stops after `patience` evaluations without improvement; the best
  parameters seen are returned,
* divergence: the objective, its gradient or the parameters became non-finite (NaN / inf, e.g. an
  overflowing step or features too large for float32). That step is never accepted: the loop stops
  with the last finite parameters and `TrainInfo.diverged` set, and it is never reported as
  `converged`. A non-finite objective at the start stops the loop before the first iteration
  (`n_iter == 0`). The `fit_*` functions raise or warn on it (`train`).

Only what changes the compiled program is static: the optimiser (`method` or `optimizer`),
`max_iter` (the length of the loss histories) and `memory_size` (the L-BFGS memory). Tolerances,
the learning rate, `period`, `patience` and `eval_every` are traced, so changing them reuses the
compiled loop. Fit options are never stored in a model.
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import optax
from jax import lax
from jaxtyping import Array, Bool, Float, Int

from lfd_common import check_choice, check_int, check_real

_METHODS = ("lbfgs", "adam")


@dataclasses.dataclass(frozen=True)
class FitOptions:
    """How a `fit_*` (or `minimize`) searches; the same fields for every model of crf_jax.

    The defaults are those of `fit_chain`, `fit_hcrf` and `fit_fcrf`; `fit_linear` defaults to
    `FitOptions.for_linear(kind)`. Change fields with `dataclasses.replace(options, ...)`. Options
    are never stored in a model. Only the optimiser, `max_iter` and `memory_size` are static; the
    rest are traced, so changing them reuses the compiled loop.

    Attributes:
        method: "lbfgs" (`optax.lbfgs(memory_size)`, zoom line search) or "adam"
            (`optax.adam(learning_rate)`).
        optimizer: Any `optax.GradientTransformation`, used instead of `method` when given (then
            `learning_rate` and `memory_size` are unused). It is part of the compiled program:
            reuse the same object to reuse the compilation.
        max_iter: Iterations at most, >= 1.
        memory_size: L-BFGS history length, >= 1.
        learning_rate: Adam's step size, > 0 (traced).
        gtol: Stop when ||g|| / max(1, ||params||) < gtol (traced).
        delta: Stop when (f_{k-period} - f_k) / |f_k| < delta (traced).
        period: Iterations over which `delta` measures the improvement, >= 1 (traced).
        patience: Early stopping after this many validation evaluations without improvement,
            >= 1 (traced), when the fit is given validation data.
        eval_every: Iterations between validation evaluations, >= 1 (traced).

    Raises:
        ValueError: Naming the field, for an unknown method, an optimizer that is not an optax
            GradientTransformation, or a value of the wrong type or outside its range.
    """

    method: str = "lbfgs"
    optimizer: optax.GradientTransformation | None = None
    max_iter: int = 200
    memory_size: int = 10
    learning_rate: float = 0.05
    gtol: float = 1e-5
    delta: float = 1e-5
    period: int = 10
    patience: int = 5
    eval_every: int = 1

    def __post_init__(self):
        check_choice(self.method, "method", _METHODS)
        if self.optimizer is not None and not isinstance(self.optimizer, optax.GradientTransformation):
            raise ValueError(f"optimizer: expected an optax.GradientTransformation or None, got "
                             f"{type(self.optimizer).__name__}")
        checked = dict(
            max_iter=check_int(self.max_iter, "max_iter", min_value=1),
            memory_size=check_int(self.memory_size, "memory_size", min_value=1),
            learning_rate=check_real(self.learning_rate, "learning_rate", min_value=0.0, exclusive_min=True),
            gtol=check_real(self.gtol, "gtol", min_value=0.0),
            delta=check_real(self.delta, "delta", min_value=0.0),
            period=check_int(self.period, "period", min_value=1),
            patience=check_int(self.patience, "patience", min_value=1),
            eval_every=check_int(self.eval_every, "eval_every", min_value=1),
        )
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @classmethod
    def for_linear(cls, kind: str = "logistic", **changes: Any) -> FitOptions:
        """`fit_linear`'s defaults for `kind`.

        L-BFGS for the smooth logistic loss, Adam (learning rate 0.01) for the non-smooth SVM
        hinge; 500 iterations, delta 1e-6, patience 10.

        Args:
            kind: "logistic" or "svm".
            **changes: Fields that override those defaults.

        Returns:
            The `FitOptions`.

        Raises:
            ValueError: Naming `kind` when it is neither, or the field of an invalid change.
        """
        check_choice(kind, "kind", ("logistic", "svm"))
        base = dict(method="lbfgs" if kind == "logistic" else "adam", max_iter=500, learning_rate=0.01,
                    delta=1e-6, patience=10)
        return cls(**{**base, **changes})


class TrainInfo(NamedTuple):
    """What `minimize` (and so every `fit_*`) did. Histories have one slot per iteration; unused slots are NaN.

    Attributes:
        n_iter: () iterations run.
        converged: () a tolerance stopped the loop (never set with a non-finite objective).
        early_stopped: () validation patience ran out.
        loss: (max_iter,) training objective after each iteration.
        val_loss: (max_iter,) validation objective where evaluated.
        best_iter: () iteration whose parameters were returned.
        diverged: () objective, gradient or parameters became non-finite: stopped, last finite
            point kept.
    """

    n_iter: Int[Array, ""]
    converged: Bool[Array, ""]
    early_stopped: Bool[Array, ""]
    loss: Float[Array, " max_iter"]
    val_loss: Float[Array, " max_iter"]
    best_iter: Int[Array, ""]
    diverged: Bool[Array, ""]


class FitResult(NamedTuple):
    """What every `fit_*` and `minimize` return.

    Attributes:
        model: The fitted parameters pytree (the model).
        info: The `TrainInfo` of the search.
    """

    model: Any
    info: TrainInfo


def l2_penalty(params: Any) -> Array:
    """sum of squares of every leaf of a parameter pytree."""
    return sum(jnp.sum(jnp.square(leaf)) for leaf in jax.tree_util.tree_leaves(params))


def _tree_norm(tree: Any) -> Array:
    return jnp.sqrt(l2_penalty(tree))


def _all_finite(*trees: Any) -> Array:
    """() bool: every element of every leaf is finite."""
    leaves = [leaf for tree in trees for leaf in jax.tree_util.tree_leaves(tree)]
    return jnp.all(jnp.stack([jnp.all(jnp.isfinite(leaf)) for leaf in leaves]))


def _optimizer(method: str, optimizer, learning_rate, memory_size: int) -> optax.GradientTransformationExtraArgs:
    if optimizer is not None:
        return optax.with_extra_args_support(optimizer)
    if method == "lbfgs":
        return optax.lbfgs(memory_size=memory_size)
    return optax.adam(learning_rate)


def _stores_value_and_grad(state) -> bool:
    """Whether the optimiser state keeps the objective's value and gradient (line searches do)."""
    find = optax.tree_utils.tree_get_all_with_path
    return len(find(state, "value")) == 1 and len(find(state, "grad")) == 1


def minimize(
    objective: Callable[[Any, Any], Array],
    params: Any,
    data: Any,
    val_data: Any = None,
    options: FitOptions | None = None,
    *,
    val_objective: Callable[[Any, Any], Array] | None = None,
) -> FitResult:
    """Minimise `objective(params, data)` (a scalar) from `params`, the whole loop in one jit.

    The solver every `fit_*` shares: optax L-BFGS, Adam or any optax optimiser, stopped by
    CRFsuite's rules (gradient, objective, `max_iter`), early stopping on validation data, or
    divergence (a non-finite objective, gradient or step is never accepted).

    Args:
        objective: (params, data) -> scalar; hashable (a module-level function or a
            `functools.partial` of one with hashable arguments).
        params: The starting parameters pytree.
        data: A pytree of arrays passed to `objective`.
        val_data: A pytree of arrays passed to `val_objective` for early stopping, or None.
        options: `FitOptions`; None: `FitOptions()`.
        val_objective: Hashable like `objective`; None: `objective`.

    Returns:
        `FitResult(params, TrainInfo)`: the best parameters seen (by validation objective, when
        given), and what the search did.

    Raises:
        ValueError: Naming `options`, when it is not a crf_jax.FitOptions.
    """
    options = FitOptions() if options is None else options
    if not isinstance(options, FitOptions):
        raise ValueError(f"options: expected a crf_jax.FitOptions, got {type(options).__name__}")
    static = (options.method, options.optimizer, options.max_iter, options.memory_size)
    traced = dict(learning_rate=options.learning_rate, gtol=options.gtol, delta=options.delta,
                  period=options.period, patience=options.patience, eval_every=options.eval_every)
    return _minimize(objective, params, data, val_data, traced, static=static, val_objective=val_objective)


@partial(jax.jit, static_argnames=("objective", "static", "val_objective"))
def _minimize(objective, params, data, val_data, traced, *, static, val_objective) -> FitResult:
    method, optimizer, max_iter, memory_size = static
    period, patience, eval_every = traced["period"], traced["patience"], traced["eval_every"]
    opt = _optimizer(method, optimizer, traced["learning_rate"], memory_size)
    fun = lambda p: objective(p, data)  # noqa: E731
    vfun = None
    if val_data is not None:
        vobj = val_objective or objective
        vfun = lambda p: vobj(p, val_data)  # noqa: E731
    state0 = opt.init(params)
    from_state = _stores_value_and_grad(state0)
    if from_state:
        vg_state = optax.value_and_grad_from_state(fun)
    value0, grad0 = jax.value_and_grad(fun)(params)
    nan_hist = jnp.full((max_iter,), jnp.nan, jnp.float32)
    big = jnp.asarray(jnp.inf, jnp.float32)

    carry0 = dict(
        params=params, state=state0, value=value0, grad=grad0, k=jnp.int32(0),
        loss=nan_hist, val=nan_hist, best_params=params, best_val=big, best_iter=jnp.int32(0),
        bad=jnp.int32(0), converged=jnp.bool_(False), early=jnp.bool_(False),
        diverged=~_all_finite(value0, grad0, params),  # a non-finite start: no iteration runs
    )

    def cond(c):
        return (c["k"] < max_iter) & ~c["converged"] & ~c["early"] & ~c["diverged"]

    def body(c):
        updates, state = opt.update(c["grad"], c["state"], c["params"], value=c["value"], grad=c["grad"],
                                    value_fn=fun)
        params = optax.apply_updates(c["params"], updates)
        if from_state:
            value, grad = vg_state(params, state=state)
        else:
            value, grad = jax.value_and_grad(fun)(params)
        k = c["k"]
        # a non-finite objective, gradient or step (an overflow) is never accepted: keep the last
        # good point and stop as diverged (never as converged)
        ok = _all_finite(value, grad, params)
        params = jax.tree_util.tree_map(lambda n, o: jnp.where(ok, n, o), params, c["params"])
        value = jnp.where(ok, value, c["value"])
        grad = jax.tree_util.tree_map(lambda n, o: jnp.where(ok, n, o), grad, c["grad"])
        loss = c["loss"].at[k].set(value.astype(jnp.float32))
        gnorm = _tree_norm(grad) / jnp.maximum(1.0, _tree_norm(params))
        past = jnp.where(k + 1 > period, loss[jnp.maximum(k - period, 0)], jnp.inf)  # f_{k+1-period}
        rel = (past - value) / jnp.maximum(jnp.abs(value), 1e-30)
        converged = ok & ((gnorm < traced["gtol"]) | (rel < traced["delta"]))
        out = dict(c, params=params, state=state, value=value, grad=grad, k=k + 1, loss=loss,
                   converged=converged, diverged=~ok)
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
    info = TrainInfo(c["k"], c["converged"], c["early"], c["loss"], c["val"], best_iter, c["diverged"])
    return FitResult(best, info)
