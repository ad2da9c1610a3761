"""Batched MJX rollouts: `vmap` over worlds, `lax.scan` over steps (the MJX / Playground style).

The entry points `worlds_from_qpos` and `batched_rollout` check their input as
`sim.grasping.rollout_grasps` does
(before anything is traced or compiled): the model is an `mjx.Model` (MJX-JAX with the Euler or
implicitfast integrator for `batched_rollout`), `qpos` is a non-empty (W, nq) real array, finite and
within the model's float dtype, `worlds` a batch of W `mjx.Data` of that model with finite qpos, qvel,
ctrl and act, `n_steps` and `record_every` positive integers with n_steps a multiple of record_every;
anything else is a `ValueError` naming the argument. Under an outer `jit` (traced arguments) only
shapes and dtypes are checked.
"""
from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from lfd_common import as_array, check_int
from sim._src.mjx_compat import mass_matrix, with_mass_matrix

# The integrators `mjx_step` orders after the constraint solver; both factorise a mass-like matrix.
_INTEGRATORS = {int(mujoco.mjtIntegrator.mjINT_EULER): mjx.euler,
                int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): mjx.implicit}


def mjx_step(mjx_model: mjx.Model, data: mjx.Data) -> mjx.Data:
    """`mjx.step` for MJX's JAX implementation, with every LAPACK call of the step on one dependency chain.

    Args:
        mjx_model: an MJX-JAX model with the Euler or implicitfast integrator.
        data: the state of one world (vmap it for a batch).

    Returns:
        The state after one step.

    Raises:
        ValueError: an integrator other than Euler and implicitfast.

    Same arithmetic as `mjx.step` (forward dynamics, then the Euler or implicitfast integrator); only
    the order XLA may run it in changes. Why: both integrators Cholesky-factorise a matrix built from
    the mass matrix (M + h·damping, M - h·dqfrc/dqvel), which is known before the constraint solver
    runs, so XLA:CPU may start that factorisation while the Newton solver runs its own. jaxlib 0.10.2
    runs a batched (vmapped) LAPACK call as `jax::ParallelBatchMap` on the intra-op thread pool and
    blocks its pool thread until the pieces are done; two such calls at once on a 2-thread pool wait
    for each other forever (gdb on a hung grasp rollout: both `tf_XLAEigen` threads in `spotrf` ->
    `ParallelBatchMap` -> `BlockingCounter::Wait`, nothing else running). Here the mass matrix the
    integrator reads depends on the solver's result, M + 0 · sum(qacc) (XLA does not fold a float
    multiplication by zero; a `lax.optimization_barrier` does not survive XLA:CPU's optimisation
    passes), so the integrator's factorisation starts after the solver. The other factorisations of
    a step are already ordered: the solver starts from `qacc_smooth`, which needs the factorised M.
    `tests/test_mjx_step.py` checks the order in XLA's optimized program.
    """
    integrate = _INTEGRATORS.get(int(mjx_model.opt.integrator))
    if integrate is None:
        raise ValueError(f"mjx_model: integrator {mjx_model.opt.integrator!r} not supported (Euler or implicitfast)")
    data = mjx.forward(mjx_model, data)
    mass = mass_matrix(data) + 0.0 * jnp.sum(data.qacc)
    return integrate(mjx_model, with_mass_matrix(data, mass))


# ----------------------------------------------------------------------------------------------
# input checks of the entry points (outside jit)
# ----------------------------------------------------------------------------------------------
def _traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


def _check_model(mjx_model, *, rollout: bool = False):
    if not isinstance(mjx_model, mjx.Model):
        raise ValueError(f"mjx_model: expected an mjx.Model (mjx.put_model(mj_model)), got {type(mjx_model).__name__}")
    if rollout:
        impl = getattr(mjx_model.impl, "value", mjx_model.impl)
        if impl != "jax":
            raise ValueError(f"mjx_model: batched_rollout steps MJX-JAX models (mjx.put_model(m, impl='jax')), "
                             f"got impl {impl!r}")
        if int(mjx_model.opt.integrator) not in _INTEGRATORS:
            raise ValueError(f"mjx_model: integrator {mjx_model.opt.integrator!r} not supported (Euler or implicitfast)")
    return mjx_model


def _check_rows(value, name: str, n_rows: int | None, n_cols: int, dtype: np.dtype, what: str):
    """A (W, n_cols) real array (W = n_rows if given, else >= 1): finite and within `dtype`'s range.

    Returned as given for traced values (only shape and dtype checked), else as a jax array of `dtype`.
    """
    rows = "W" if n_rows is None else n_rows
    if _traced(value):
        if value.ndim != 2 or value.shape[1] != n_cols or value.shape[0] < 1 or (
                n_rows is not None and value.shape[0] != n_rows):
            raise ValueError(f"{name}: expected shape ({rows}, {n_cols}) ({what}), got {tuple(value.shape)}")
        if not jnp.issubdtype(value.dtype, jnp.floating):
            raise ValueError(f"{name}: expected a floating-point array, got dtype {value.dtype}")
        return value
    arr = as_array(value, name, shape=(n_rows, n_cols), dtype=None, finite=False)
    _check_real_values(arr, name, dtype)
    return jnp.asarray(arr, dtype)


def _check_real_values(arr: np.ndarray, name: str, dtype: np.dtype) -> None:
    """Real (not complex, not text), finite, and within `dtype`'s range; ValueError naming `name`."""
    if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool) or np.iscomplexobj(arr):
        raise ValueError(f"{name}: expected a real array, got dtype {arr.dtype}")
    arr = arr.astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains {int(np.sum(~np.isfinite(arr)))} NaN or infinite value(s)")
    limit = np.finfo(dtype).max
    if arr.size and np.max(np.abs(arr)) > limit:
        raise ValueError(f"{name}: values up to {np.max(np.abs(arr)):.3g} overflow {dtype.name} (max {limit:.3g})")


def _check_worlds(mjx_model, worlds):
    if not isinstance(worlds, mjx.Data):
        raise ValueError(f"worlds: expected a batch of mjx.Data (from worlds_from_qpos), got {type(worlds).__name__}")
    if worlds.impl != mjx_model.impl:
        raise ValueError(f"worlds: MJX data of impl {worlds.impl.value!r}, but mjx_model is {mjx_model.impl.value!r}")
    qpos = worlds.qpos
    if qpos.ndim != 2 or qpos.shape[1] != mjx_model.nq or qpos.shape[0] < 1:
        raise ValueError(f"worlds: expected a batch of W >= 1 worlds of this model, qpos (W, {mjx_model.nq}), "
                         f"got qpos shape {tuple(qpos.shape)}")
    n = qpos.shape[0]
    dtype = np.dtype(mjx_model.qpos0.dtype)
    for field, size in (("qpos", mjx_model.nq), ("qvel", mjx_model.nv), ("ctrl", mjx_model.nu),
                        ("act", mjx_model.na)):
        value = getattr(worlds, field)
        if tuple(value.shape) != (n, size):
            raise ValueError(f"worlds.{field}: expected shape ({n}, {size}), got {tuple(value.shape)}")
        if size and not _traced(value):
            _check_real_values(np.asarray(value), f"worlds.{field}", dtype)
    return worlds


def worlds_from_qpos(mjx_model: mjx.Model, qpos: jax.Array) -> mjx.Data:
    """A batch of MJX worlds at rest, one per row of joint positions, forward kinematics done.

    Args:
        mjx_model: an `mjx.Model` (`mjx.put_model(mj_model)`).
        qpos: (W, nq) non-empty, real and finite, computed in the model's float dtype.

    Returns:
        The batch of W `mjx.Data`.

    Raises:
        ValueError: a model that is not an `mjx.Model`, or bad qpos, naming the argument.
    """
    _check_model(mjx_model)
    dtype = np.dtype(mjx_model.qpos0.dtype)
    qpos = _check_rows(qpos, "qpos", None, mjx_model.nq, dtype, "one row of nq joint positions per world")
    return _worlds_from_qpos(mjx_model, qpos)


def _check_rollout(mjx_model, worlds, n_steps, record_every):
    _check_model(mjx_model, rollout=True)
    _check_worlds(mjx_model, worlds)
    n_steps = check_int(n_steps, "n_steps", min_value=1)
    record_every = check_int(record_every, "record_every", min_value=1)
    if n_steps % record_every:
        raise ValueError(f"n_steps: must be a multiple of record_every={record_every}, got {n_steps}")
    return mjx_model, worlds, n_steps, record_every


def batched_rollout(mjx_model: mjx.Model, worlds: mjx.Data, n_steps: int,
                    record_every: int = 1) -> tuple[mjx.Data, jax.Array]:
    """Step every world of a batch `n_steps` times, recording the joint positions.

    Inputs are checked (module docstring); `batched_rollout.lower(...)` checks them too and lowers the
    jitted program.

    Args:
        mjx_model: an MJX-JAX model with the Euler or implicitfast integrator.
        worlds: a batch of W `mjx.Data` of that model (`worlds_from_qpos`).
        n_steps: steps (a positive multiple of `record_every`).
        record_every: record every this many steps, so long rollouts do not hold every step.

    Returns:
        (final worlds, qpos trajectory (n_steps // record_every, W, nq)).

    Raises:
        ValueError: bad input, naming the argument.
    """
    return _batched_rollout(*_check_rollout(mjx_model, worlds, n_steps, record_every))


def _lower(mjx_model: mjx.Model, worlds: mjx.Data, n_steps: int, record_every: int = 1):
    return _batched_rollout.lower(*_check_rollout(mjx_model, worlds, n_steps, record_every))


batched_rollout.lower = _lower


@jax.jit
def _worlds_from_qpos(mjx_model: mjx.Model, qpos: jax.Array) -> mjx.Data:
    template = mjx.make_data(mjx_model)
    return jax.vmap(lambda q: mjx.forward(mjx_model, template.replace(qpos=q)))(qpos)


@partial(jax.jit, static_argnames=("n_steps", "record_every"))
def _batched_rollout(mjx_model: mjx.Model, worlds: mjx.Data, n_steps: int, record_every: int = 1):
    step_all = jax.vmap(mjx_step, in_axes=(None, 0))

    def chunk(data, _):
        data = jax.lax.fori_loop(0, record_every, lambda _, d: step_all(mjx_model, d), data)
        return data, data.qpos

    final, trajectory = jax.lax.scan(chunk, worlds, None, length=n_steps // record_every)
    return final, jnp.asarray(trajectory)
