"""The task controller's physics backends (`TaskOptions.backend`): the MJX-JAX world (`MjxTaskSim`) steps
the same control periods as the native one (`TaskSim`) to the same state, reads the same contacts, and a
scene MJX-JAX cannot collide is refused naming the backend.

Cost: one compile of the MJX control period (the manipulator scene's `mjx_step` in a scan; about a
minute on the shared 2-core machine) and 40 control periods on each backend. Whole tasks on both
backends (about 30 s each on MJX-JAX on the CPU) are compared by `python -m experiments.bench.task_backends`.
"""
import numpy as np
import pytest

from sim import TaskOptions, TaskSpec, run_task
from sim.robot import HOME_Q, MjxTaskSim, TaskSim, forward_kinematics, task_scene

SPEC = TaskSpec(objects=(1,), object_xy=[(0.0, -0.40)], target=0, grasp=1, place_xy=(0.20, -0.40), hand="barrett")
N_PERIODS = 40          # 0.8 s: the palm rises 8 cm from home, the arm's servos track it
STATE_TOL_M = 1e-3      # float32 MJX against float64 MuJoCo over 400 steps of free arm motion


def test_mjx_periods_follow_the_native_ones_and_read_the_same_contacts():
    scene = task_scene(SPEC.hand, SPEC.objects, tuple(map(tuple, SPEC.object_xy)))
    open_ = np.zeros(len(scene.arm.hand_ctrl))
    native, mjx = TaskSim(scene, SPEC, open_), MjxTaskSim(scene, SPEC, open_, TaskOptions(backend="mjx-jax"))
    pos, rot = (np.asarray(a, float) for a in forward_kinematics(scene.chain, HOME_Q))
    for k in range(1, N_PERIODS + 1):
        target = pos + [0.0, 0.0, 0.1 * k / N_PERIODS]
        native.step(target, rot, open_)
        mjx.step(target, rot, open_)
    assert np.linalg.norm(native.palm() - (pos + [0.0, 0.0, 0.1])) < 0.03         # it moved the arm
    np.testing.assert_allclose(mjx.palm(), native.palm(), atol=STATE_TOL_M)
    np.testing.assert_allclose(mjx.hand_q(), native.hand_q(), atol=1e-2)
    np.testing.assert_allclose(mjx.obj_pos(), native.obj_pos(), atol=STATE_TOL_M)
    np.testing.assert_allclose(mjx.obj_rot(), native.obj_rot(), atol=1e-3)
    np.testing.assert_allclose(mjx.sensordata, native.sensordata, atol=1e-2, rtol=1e-2)
    # the object stands on the table on both; the hand, 20 cm above it, touches nothing
    assert native.touches([scene.table_geom]) and mjx.touches([scene.table_geom])
    assert not native.touches(scene.robot_geoms) and not mjx.touches(scene.robot_geoms)
    assert mjx.t == pytest.approx(native.t)


def test_backend_is_checked_and_an_mjx_scene_without_its_collisions_is_refused():
    with pytest.raises(ValueError, match="backend"):
        TaskOptions(backend="warp")
    # the Pinch cube (a box) beside the arm's cylinders: a pair MJX-JAX does not collide
    spec = TaskSpec(objects=(9,), object_xy=[(0.0, -0.40)], target=0, grasp=9, place_xy=(0.20, -0.40))
    with pytest.raises(ValueError, match="backend"):
        run_task(spec, options=TaskOptions(backend="mjx-jax"))
