"""Property tests (hypothesis) of sim's public promise, beside `tests/test_sim_inputs.py`
(the MJX entry points): valid in -> a scene MuJoCo compiles / an image of the asked size; invalid in
-> `ValueError` whose message starts with the argument's name. One compiled scene, small images."""
import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sim

SCENE = mujoco.MjModel.from_xml_string(sim.tabletop_drop_scene(2))
QPOS0 = SCENE.qpos0.copy()


@settings(max_examples=10, deadline=None)
@given(n_objects=st.integers(1, 16), timestep_s=st.floats(1e-4, 0.01))
def test_scene_compiles_with_seven_coordinates_per_object(n_objects, timestep_s):
    model = mujoco.MjModel.from_xml_string(sim.tabletop_drop_scene(n_objects, timestep_s))
    assert model.nq == 7 * n_objects
    assert math.isclose(model.opt.timestep, timestep_s, rel_tol=1e-6)


@settings(max_examples=20, deadline=None)
@given(st.one_of(
    st.tuples(st.just("n_objects"), st.sampled_from([0, 17, -1, 2.5, True, "3"]), st.just(0.004)),
    st.tuples(st.just("timestep_s"), st.just(3), st.sampled_from([0.0, -1e-3, math.nan, math.inf, 1.0, "x"])),
))
def test_scene_rejects_bad_arguments_by_name(case):
    name, n_objects, timestep_s = case
    with pytest.raises(ValueError, match=f"^{name}:"):
        sim.tabletop_drop_scene(n_objects, timestep_s)


@settings(max_examples=6, deadline=None)
@given(width=st.integers(8, 64), height=st.integers(8, 48), shift=st.floats(-0.1, 0.1))
def test_render_frame_gives_an_rgb_image_of_the_asked_size(width, height, shift):
    qpos = QPOS0.copy()
    qpos[0] += shift
    image = sim.render_frame(SCENE, qpos, width=width, height=height)
    assert image.shape == (height, width, 3) and image.dtype == np.uint8


@settings(max_examples=20, deadline=None)
@given(st.one_of(
    st.tuples(st.just("width"), st.sampled_from([0, 7, 10_000, 12.5])),
    st.tuples(st.just("height"), st.sampled_from([0, 7, 10_000, None])),
    st.tuples(st.just("qpos"), st.sampled_from(["nan", "inf", "short"])),
))
def test_render_frame_rejects_bad_arguments_by_name(case):
    name, bad = case
    kwargs = {"width": 32, "height": 24}
    qpos = QPOS0.copy()
    if name == "qpos":
        qpos = qpos[:-1] if bad == "short" else np.where(np.arange(len(qpos)) == 0, float(bad), qpos)
    else:
        kwargs[name] = bad
    with pytest.raises(ValueError, match=f"^{name}:"):
        sim.render_frame(SCENE, qpos, **kwargs)


@pytest.mark.parametrize("backend", ["vulkan", "", None])
def test_setup_rendering_names_a_bad_backend(backend):
    with pytest.raises(ValueError, match="^backend:"):
        sim.setup_rendering(backend)
