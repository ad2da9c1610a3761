"""Robot hand models: compile, MJX support, wrist kinematics, couplings, touch sensors, bad input."""
import mujoco
import numpy as np
import pytest
from mujoco import mjx
from scipy.spatial.transform import Rotation

from sim.grasping import GRASP_CLASSES, GRASP_OBJECTS, ROBOT_GRASPS
from sim.grasping import initial_qpos, object_gravcomp
from sim.grasping import TrialParams
from sim._src.grasp_strategy import wrist_angles
from sim.hands import HAND_NAMES, grasp_model, hand_joint_qpos, hand_spec, preshape


@pytest.fixture(scope="module", params=HAND_NAMES)
def scene(request):
    model, layout = grasp_model(request.param)
    return request.param, model, layout


def test_model_sizes(scene):
    hand, model, layout = scene
    spec = hand_spec(hand)
    assert model.nu == 6 + len(spec.dofs) == layout.n_ctrl
    assert layout.n_links == 1 + 2 * len(spec.fingers)
    assert layout.contact.shape == (layout.n_links, len(GRASP_CLASSES))
    assert {model.geom_type[model.geom(ln).id] for ln in spec.link_names} == {int(mujoco.mjtGeom.mjGEOM_CAPSULE)}
    assert len(spec.dofs) == {"barrett": 4, "karlsruhe": 8}[hand]


def test_every_collision_pair_is_supported_by_mjx_jax(scene):
    """put_model raises NotImplementedError for a geom pair MJX-JAX cannot collide."""
    _, model, _ = scene
    mjx.put_model(model, impl="jax")


def test_wrist_angles_reproduce_the_hand_rotation(scene):
    """Hinges Rz(a) Rx(b) Ry(c) set from `wrist_angles` give the rotation asked for (FK vs scipy)."""
    _, model, layout = scene
    rots = Rotation.random(5, random_state=0).as_matrix()
    rots = rots[np.abs(rots[:, 2, 1]) < 0.9]           # away from the chain's singularity (hand y vertical)
    data = mujoco.MjData(model)
    hand_body = model.body("hand").id
    for rot, angles in zip(rots, wrist_angles(rots)):
        data.qpos[layout.wrist_qpos] = [0.1, -0.2, 0.3, *angles]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.xmat[hand_body].reshape(3, 3), rot, atol=1e-9)
        np.testing.assert_allclose(data.xpos[hand_body], [0.1, -0.2, 0.3], atol=1e-12)


def _hand_in_air(model, layout, hand, targets):
    data = mujoco.MjData(model)
    data.qpos[:] = hand_joint_qpos(model, hand, targets)
    data.qpos[layout.wrist_qpos[2]] = 0.5
    data.ctrl[2] = 0.5
    data.ctrl[6:] = targets
    return data


def test_fingers_close_towards_the_palm_normal_and_couplings_hold(scene):
    """Closing the Wrap/Power preshape moves every fingertip towards the palm normal's side (+z of the
    hand), and coupled joints follow their drivers (equality constraints)."""
    hand, model, layout = scene
    grasp = ROBOT_GRASPS[hand][0]
    open_, closed = preshape(hand, grasp)
    data = _hand_in_air(model, layout, hand, open_)
    mujoco.mj_forward(model, data)
    tips_open = data.site_xpos[layout.fingertip_site].copy()
    data.ctrl[6:] = closed
    for _ in range(600):
        mujoco.mj_step(model, data)
    tips_closed = data.site_xpos[layout.fingertip_site]
    hand_rot = data.xmat[model.body("hand").id].reshape(3, 3)
    centre = data.xpos[model.body("hand").id]
    radial = lambda p: np.linalg.norm(((p - centre) @ hand_rot)[:, :2], axis=1)  # noqa: E731
    assert np.all(radial(tips_closed) < radial(tips_open))
    np.testing.assert_allclose(data.qpos[layout.hand_qpos], closed, atol=0.08)
    c0, c1 = hand_spec(hand).distal_coupling
    for f in hand_spec(hand).fingers:
        if f.distal_dof is None:
            prox, dist = data.joint(f"{f.name}_prox").qpos[0], data.joint(f"{f.name}_dist").qpos[0]
            assert dist == pytest.approx(c0 + c1 * prox, abs=0.02)


def test_touch_sensor_feels_an_object_on_the_palm_only(scene):
    """An object resting on the upturned palm loads the palm's touch sensor with about its weight (the
    fingers in the open preshape of the hand's first grasp: the Karlsruhe thumb extended away)."""
    hand, model, layout = scene
    rot = np.eye(3)                      # palm normal +z: the palm faces up
    fingers = preshape(hand, ROBOT_GRASPS[hand][0])[0][None]
    params = TrialParams(goal=np.zeros((1, 3)), approach=np.array([[0, 0, 1.0]]), wrist=wrist_angles(rot[None]),
                         start=np.array([[0, 0, 0.3]]), standoff=np.zeros(1), volar=np.ones(1, bool),
                         tactile=np.ones(1, bool), open_=fingers, closed=fingers, obj=np.array([4]),
                         hold_s=np.ones(1))
    obj = GRASP_OBJECTS[GRASP_CLASSES[4]]       # the ball
    palm_top = 0.3
    qpos = initial_qpos(model, hand, layout, params, np.array([[0.0, 0.0, palm_top + obj.size[0] + 0.002]]))
    model.body_gravcomp[:] = object_gravcomp(model, layout, params.obj)[0]
    data = mujoco.MjData(model)
    data.qpos[:] = qpos[0]
    data.ctrl[:6] = [0, 0, 0.3, *params.wrist[0]]
    data.ctrl[6:] = fingers[0]
    for _ in range(300):
        mujoco.mj_step(model, data)
    touch = data.sensordata[layout.touch]
    weight = obj.mass_kg * 9.81
    assert touch[0] == pytest.approx(weight, rel=0.15)
    assert np.all(touch[1:] < 0.05 * weight)


def test_bad_input():
    with pytest.raises(ValueError, match="hand"):
        hand_spec("shadow")
    with pytest.raises(ValueError, match="robot_grasp"):
        preshape("barrett", "Power")
