"""The robot's task from what was recognised: the recognised object, grasp and place as a
`sim.TaskSpec`, run by the MAP §III grasp strategy (Romero et al. 2009), the arm approaching along the
reach PHMM's synthesised movement (PHMM, Herzog et al. 2008 Humanoids §III synthesis)."""
from __future__ import annotations

import numpy as np

import phmm_jax as P
import sim
from lfd_jax.imitation._src.area import TableArea, xy_to_phi
from lfd_jax.imitation._src.recognition import Recognised
from sim.grasping import GRASP_CLASSES


def synthesised_reach(reach_phmm: P.PHMM, object_xy: np.ndarray, length: int = 50,
                      area: TableArea = TableArea()) -> np.ndarray:
    """The reach of a person to an object: the reach PHMM's mean movement for that target (PHMM,
    Humanoids 2008 §III synthesis, `phmm_jax.synthesize`).

    The robot's approach follows its shape (`sim.task_motion.retarget_path`).

    Args:
        reach_phmm: the reach PHMM.
        object_xy: (2,) the object's table position, world m.
        length: frames of the synthesised movement.
        area: the table rectangle the PHMM's grid spans.

    Returns:
        (length, 3) hand - face in world axes, m.

    Raises:
        ValueError: `object_xy` is not 2 finite values.
    """
    xy = np.asarray(object_xy, float)
    if xy.shape != (2,) or not np.isfinite(xy).all():
        raise ValueError(f"object_xy: expected 2 finite values, got {xy!r}")
    return np.asarray(P.synthesize(reach_phmm, xy_to_phi(object_xy, area), length), np.float64)


def task_spec(r: Recognised, objects: tuple[int, ...], objects_xy: np.ndarray, hand: str = "barrett") -> sim.TaskSpec:
    """The `sim.TaskSpec` of what was recognised (MAP §III).

    The recognised object among the scene's objects, the recognised grasp (a pointing: the grasp class
    of the object itself), the hand-over spot or the recognised place; the orientation is the
    controller's canonical one (the recognised orientation is relative to the camera and not turned
    into the world here).

    Args:
        r: what was recognised (`recognise_demo`), with a movement found.
        objects: the robot scene's objects (`sim.grasping.GRASP_OBJECTS` classes), one per row of
            `objects_xy`.
        objects_xy: (K, 2) where they stand, world m.
        hand: the robot hand ("barrett" or "karlsruhe").

    Returns:
        The `sim.TaskSpec`.

    Raises:
        ValueError: `r` holds no movement or an object out of range, or `objects` and `objects_xy`
            disagree.
    """
    objects_xy = np.asarray(objects_xy, float)
    if r.kind is None:
        raise ValueError("r: no movement was recognised (kind is None): there is no task")
    if objects_xy.ndim != 2 or objects_xy.shape != (len(objects), 2):
        raise ValueError(f"objects_xy: expected ({len(objects)}, 2) positions (one per object), got {objects_xy.shape}")
    if not 0 <= r.target < len(objects):
        raise ValueError(f"r: target {r.target} is not one of the {len(objects)} objects")
    grasp = r.grasp if (r.kind == "transfer" and r.grasp in GRASP_CLASSES) else objects[r.target]
    return sim.TaskSpec(objects=tuple(objects), object_xy=objects_xy, target=int(r.target),
                        grasp=int(grasp), place_xy=np.asarray(r.place_xy, float), hand_rot=None, tactile=True,
                        hand=hand)


def robot_task(r: Recognised, objects: tuple[int, ...], objects_xy: np.ndarray, reach_phmm: P.PHMM | None = None,
               hand: str = "barrett", seed: int = 0, render: bool = False, area: TableArea = TableArea()):
    """The robot repeats what was recognised (`sim.run_task`, MAP §III grasp strategy through the
    mapping table) with the `task_spec`.

    Args:
        r: what was recognised (`recognise_demo`), with a movement found.
        objects: the robot scene's objects (`sim.grasping.GRASP_OBJECTS` classes).
        objects_xy: (K, 2) where they stand, world m.
        reach_phmm: the arm approaches along the synthesised reach to the object
            (`synthesised_reach`); None: a straight line.
        hand: the robot hand ("barrett" or "karlsruhe").
        seed: the grasp plan's hand-pose noise, >= 0.
        render: record the robot's video.
        area: the table rectangle the reach PHMM's grid spans.

    Returns:
        The `sim.TaskResult`.

    Raises:
        ValueError: as `task_spec`.
    """
    spec = task_spec(r, objects, objects_xy, hand)
    path = synthesised_reach(reach_phmm, spec.object_xy[spec.target], area=area) if reach_phmm is not None else None
    return sim.run_task(spec, approach_path=path, seed=seed, options=sim.TaskOptions(render=render))
