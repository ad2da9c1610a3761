"""Input checks of sim's MJX entry points (`worlds_from_qpos`, `batched_rollout`): bad input is a
`ValueError` naming the argument, raised before anything is traced or compiled (so these tests compile
no physics)."""
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mujoco import mjx

import sim

_XML = """<mujoco>
  <option timestep="0.004"/>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.3"><joint name="hinge" axis="0 1 0"/><geom type="sphere" pos="0.2 0 0" size="0.05"/></body>
    <body pos="0.2 0 0.2"><freejoint/><geom type="sphere" size="0.03"/></body>
  </worldbody>
  <actuator><motor joint="hinge"/></actuator>
</mujoco>"""


@pytest.fixture(scope="module")
def scene():
    model = mujoco.MjModel.from_xml_string(_XML)
    mjx_model = mjx.put_model(model, impl="jax")
    one = mjx.make_data(mjx_model)
    worlds = jax.tree.map(lambda x: jnp.broadcast_to(x, (2, *jnp.shape(x))), one)  # 2 worlds, no forward pass
    return model, mjx_model, one, worlds


def _raises(match, fn, *args, **kwargs):
    with pytest.raises(ValueError, match=match):
        fn(*args, **kwargs)


def test_mjx_entry_points_check_their_input(scene):
    model, mjx_model, one, worlds = scene
    nq = model.nq
    good = np.tile(model.qpos0, (2, 1))
    # worlds_from_qpos: the model and qpos (W, nq), real, finite, within float32
    _raises("mjx_model: expected an mjx.Model", sim.worlds_from_qpos, model, good)
    _raises(r"qpos: expected shape \(\?, %d\)" % nq, sim.worlds_from_qpos, mjx_model, good[:, :-1])
    _raises("qpos: expected shape", sim.worlds_from_qpos, mjx_model, good[0])  # one world needs a row
    _raises("qpos: must not be empty", sim.worlds_from_qpos, mjx_model, good[:0])
    for bad_value, match in ((np.nan, "qpos: contains 1 NaN"), (np.inf, "qpos: contains 1 NaN"),
                             (1e39, "qpos: values up to 1e\\+39 overflow float32")):
        bad = good.copy()
        bad[1, 2] = bad_value
        _raises(match, sim.worlds_from_qpos, mjx_model, bad)
    _raises("qpos: expected a real array", sim.worlds_from_qpos, mjx_model, good.astype(complex))
    _raises("qpos: expected a numeric array", sim.worlds_from_qpos, mjx_model, np.full((2, nq), "a"))
    _raises("qpos: ", sim.worlds_from_qpos, mjx_model, [[0.0] * nq, [0.0]])  # ragged
    # batched_rollout: the model (MJX-JAX, Euler / implicitfast), a batch of worlds, the step counts
    _raises("mjx_model: expected an mjx.Model", sim.batched_rollout, model, worlds, 4)
    _raises("worlds: expected a batch of mjx.Data", sim.batched_rollout, mjx_model, good, 4)
    _raises(r"worlds: expected a batch of W >= 1 worlds", sim.batched_rollout, mjx_model, one, 4)  # unbatched
    for field in ("qpos", "qvel", "ctrl"):
        value = np.array(getattr(worlds, field))
        value[1, 0] = np.nan
        _raises(f"worlds.{field}: contains 1 NaN", sim.batched_rollout, mjx_model,
                worlds.replace(**{field: jnp.asarray(value)}), 4)
    _raises(r"worlds.qvel: expected shape \(2, %d\)" % model.nv, sim.batched_rollout, mjx_model,
            worlds.replace(qvel=worlds.qvel[:, :-1]), 4)
    for n_steps in (0, -1, 2.5, True, "4"):
        _raises("n_steps", sim.batched_rollout, mjx_model, worlds, n_steps)
    _raises("record_every", sim.batched_rollout, mjx_model, worlds, 4, 0)
    _raises("n_steps: must be a multiple of record_every=3", sim.batched_rollout, mjx_model, worlds, 4, 3)
    rk4 = mujoco.MjModel.from_xml_string(_XML.replace('timestep="0.004"', 'timestep="0.004" integrator="RK4"'))
    _raises("mjx_model: integrator", sim.batched_rollout, mjx.put_model(rk4, impl="jax"), worlds, 4)
    # .lower (the demo's compile-apart path) checks the same before lowering
    _raises("n_steps", sim.batched_rollout.lower, mjx_model, worlds, 0)
    _raises("worlds", sim.batched_rollout.lower, mjx_model, one, 4)


@settings(max_examples=20, deadline=None)
@given(row=st.integers(0, 2), col=st.integers(0, 7), value=st.sampled_from([np.nan, np.inf, -np.inf, 1e39, -1e300]))
def test_any_bad_qpos_entry_is_named(scene, row, col, value):
    model, mjx_model, _, _ = scene
    qpos = np.tile(model.qpos0, (3, 1))
    qpos[row, col] = value
    with pytest.raises(ValueError, match="qpos: "):
        sim.worlds_from_qpos(mjx_model, qpos)
