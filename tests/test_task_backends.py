"""The task controller's physics backends (`TaskOptions.backend`): a backend is checked, and a scene
MJX-JAX cannot collide is refused naming the backend.

That the MJX-JAX world (`MjxTaskSim`) ends the same tasks as the native one (`TaskSim`) is checked by
`python -m experiments.bench.task_backends`, not here: the MJX control period of the manipulator scene
compiles for about a minute on two cores, and a whole task then takes 20-40 s, more than the suite's
budget allows.
"""
import pytest

from sim import TaskOptions, TaskSpec, run_task


def test_backend_is_checked_and_an_mjx_scene_without_its_collisions_is_refused():
    with pytest.raises(ValueError, match="backend"):
        TaskOptions(backend="warp")
    # the Pinch cube (a box) beside the arm's cylinders: a pair MJX-JAX does not collide
    spec = TaskSpec(objects=(9,), object_xy=[(0.0, -0.40)], target=0, grasp=9, place_xy=(0.20, -0.40))
    with pytest.raises(ValueError, match="backend"):
        run_task(spec, options=TaskOptions(backend="mjx-jax"))
