"""Batched MJX rollouts: `vmap` over worlds, `lax.scan` over steps (the MJX / Playground style)."""
from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
from mujoco import mjx


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
    step_all = jax.vmap(mjx.step, in_axes=(None, 0))

    def chunk(data, _):
        data = jax.lax.fori_loop(0, record_every, lambda _, d: step_all(mjx_model, d), data)
        return data, data.qpos

    final, trajectory = jax.lax.scan(chunk, worlds, None, length=n_steps // record_every)
    return final, jnp.asarray(trajectory)
