"""sim._mjx_compat: the private MJX fields sim relies on exist and mean what the code assumes."""
import warnings

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from mujoco import mjx

from sim._src import mjx_compat as compat

# a damped pendulum (implicit damping) and a free ball 1 cm into the floor: one penetrating contact
_XML = """<mujoco>
  <option timestep="0.004" integrator="implicitfast"/>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.3"><joint axis="0 1 0" damping="0.5"/><geom type="sphere" pos="0.2 0 0" size="0.05"/></body>
    <body pos="0.2 0 0.02"><freejoint/><geom type="sphere" size="0.03"/></body>
  </worldbody>
</mujoco>"""


@pytest.fixture(scope="module")
def scene():
    model = mujoco.MjModel.from_xml_string(_XML)
    mjx_model = mjx.put_model(model, impl="jax")
    data = jax.jit(mjx.forward)(mjx_model, mjx.make_data(model, impl="jax"))
    ref = mujoco.MjData(model)
    mujoco.mj_forward(model, ref)
    return model, mjx_model, data, ref


def test_installed_mjx_is_in_the_supported_range():
    lo, hi = compat.SUPPORTED_MJX
    assert lo <= compat.mjx_version()[:2] < hi


def test_mass_matrix_is_mujocos(scene):
    model, _, data, ref = scene
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, ref, full)
    np.testing.assert_allclose(np.asarray(compat.mass_matrix(data)), full, rtol=1e-5, atol=1e-8)


def test_integrator_reads_the_replaced_mass_matrix(scene):
    _, mjx_model, data, _ = scene
    same = mjx.implicit(mjx_model, compat.with_mass_matrix(data, compat.mass_matrix(data)))
    np.testing.assert_array_equal(np.asarray(same.qvel), np.asarray(mjx.implicit(mjx_model, data).qvel))
    heavier = mjx.implicit(mjx_model, compat.with_mass_matrix(data, 2.0 * compat.mass_matrix(data)))
    dv = np.asarray(same.qvel - data.qvel)
    np.testing.assert_allclose(np.asarray(heavier.qvel - data.qvel), dv / 2, rtol=0.05, atol=1e-7)


def test_contact_distances_are_signed_distances(scene):
    _, _, data, ref = scene
    dist = np.asarray(compat.contact_distances(data))
    assert dist.ndim == 1 and dist.shape[0] >= ref.ncon
    assert np.sum(dist < 0) == ref.ncon == 1  # only the ball penetrates
    np.testing.assert_allclose(dist.min(), ref.contact.dist[0], atol=1e-6)
    batched = jax.tree.map(lambda x: jnp.stack([x, x]), data)
    assert compat.contact_distances(batched).shape == (2, dist.shape[0])  # per world


def test_contact_count_is_absent_on_mjx_jax_and_missing_fields_are_named(scene):
    _, _, data, _ = scene
    assert compat.contact_count(data) is None
    with pytest.raises(RuntimeError, match="'_impl.nacon'"):
        compat._field(data, "_impl.nacon")


def test_version_outside_the_range_warns(monkeypatch):
    monkeypatch.setattr(compat, "mjx_version", lambda: (9, 0, 0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        compat._check_version()
    assert any("outside the range" in str(w.message) for w in caught)
