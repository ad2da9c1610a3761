"""Batched MJX rollouts: `vmap` over worlds, `lax.scan` over steps (the MJX / Playground style)."""
from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import mujoco
from mujoco import mjx

from sim._mjx_compat import mass_matrix, with_mass_matrix

# The integrators `mjx_step` orders after the constraint solver; both factorise a mass-like matrix.
_INTEGRATORS = {int(mujoco.mjtIntegrator.mjINT_EULER): mjx.euler,
                int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): mjx.implicit}


def mjx_step(mjx_model: mjx.Model, data: mjx.Data) -> mjx.Data:
    """`mjx.step` for MJX's JAX implementation, with every LAPACK call of the step on one dependency chain.

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
    `tests/test_mjx_step.py` checks the order in XLA's optimized program. Integrators other than
    Euler and implicitfast: ValueError.
    """
    integrate = _INTEGRATORS.get(int(mjx_model.opt.integrator))
    if integrate is None:
        raise ValueError(f"mjx_model: integrator {mjx_model.opt.integrator!r} not supported (Euler or implicitfast)")
    data = mjx.forward(mjx_model, data)
    mass = mass_matrix(data) + 0.0 * jnp.sum(data.qacc)
    return integrate(mjx_model, with_mass_matrix(data, mass))


@jax.jit
def worlds_from_qpos(mjx_model: mjx.Model, qpos: jax.Array) -> mjx.Data:
    """A batch of MJX data, one world per row of `qpos` (W, nq), at rest, forward kinematics done."""
    template = mjx.make_data(mjx_model)
    return jax.vmap(lambda q: mjx.forward(mjx_model, template.replace(qpos=q)))(qpos)


@partial(jax.jit, static_argnames=("n_steps", "record_every"))
def batched_rollout(mjx_model: mjx.Model, worlds: mjx.Data, n_steps: int, record_every: int = 1):
    """Step every world `n_steps` times; return (final worlds, qpos trajectory (n_steps // record_every, W, nq)).

    `record_every` thins the recorded trajectory so long rollouts do not hold every step.
    """
    if n_steps % record_every:
        raise ValueError(f"n_steps: must be a multiple of record_every={record_every}, got {n_steps}")
    step_all = jax.vmap(mjx_step, in_axes=(None, 0))

    def chunk(data, _):
        data = jax.lax.fori_loop(0, record_every, lambda _, d: step_all(mjx_model, d), data)
        return data, data.qpos

    final, trajectory = jax.lax.scan(chunk, worlds, None, length=n_steps // record_every)
    return final, jnp.asarray(trajectory)
