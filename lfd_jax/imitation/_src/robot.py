"""The robot's task from what was recognised: the recognised object, grasp and place as a
`sim.TaskSpec`, run by the MAP §III grasp strategy (Romero et al. 2009), the arm approaching along the
reach PHMM's synthesised movement (PHMM, Herzog et al. 2008 Humanoids §III synthesis)."""
from __future__ import annotations

import numpy as np

import phmm_jax as P
import sim
from lfd_jax.imitation._src.area import TableArea, xy_to_phi
from lfd_jax.imitation._src.recognition import Recognised
from lfd_common import quat_to_matrix
from sim.grasping import GRASP_CLASSES
from sim.hands import hand_pose_in_world

# The viewing frame V of a database view (`sim.grasping.view_euler`: x from the hand to the camera, z the
# image's up, y = z x x the image's right) in camera axes x right, y down, z forward: columns V_x, V_y, V_z.
_CAMERA_FROM_VIEW = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])


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


def hand_rotation(grasp: int, view_quat: np.ndarray, camera_rot: np.ndarray) -> np.ndarray:
    """The human hand's orientation in the world from the orientation GRASP eq. 4 recognised.

    Eq. 4 gives the viewing frame V of the database views nearest the query (`sim.grasping.view_euler`)
    in the frame of the grasp's scene, in which the hand has the pose `sim.hands.hand_pose_in_world`.
    Taking the demonstration's camera for the view's camera places that frame in the world:
    world <- grasp scene = world <- camera . camera <- V . V^T.

    Args:
        grasp: the recognised grasp class (`sim.grasping.GRASP_CLASSES`).
        view_quat: (4,) the recognised orientation, a quaternion (w, x, y, z) of V (`Recognised.grasp_quat`).
        camera_rot: (3, 3) the world -> camera rotation of the view the hand was recognised in, camera axes
            x right, y down, z forward (`camera_rotation`).

    Returns:
        (3, 3) the hand's rotation in the world (columns: the human hand's axes; `sim.TaskSpec.hand_rot`).

    Raises:
        ValueError: an unknown grasp class, a quaternion that is not 4 finite values of non-zero norm, or a
            `camera_rot` that is not a rotation.
    """
    if grasp not in GRASP_CLASSES:
        raise ValueError(f"grasp: expected one of {GRASP_CLASSES}, got {grasp!r}")
    q = np.asarray(view_quat, float)
    if q.shape != (4,) or not np.isfinite(q).all() or np.linalg.norm(q) < 1e-9:
        raise ValueError(f"view_quat: expected a quaternion of 4 finite values, not all zero, got {view_quat!r}")
    camera_rot = np.asarray(camera_rot, float)
    if (camera_rot.shape != (3, 3) or not np.isfinite(camera_rot).all()
            or np.abs(camera_rot @ camera_rot.T - np.eye(3)).max() > 1e-6 or np.linalg.det(camera_rot) <= 0):
        raise ValueError("camera_rot: expected a (3, 3) rotation matrix (orthonormal, det +1)")
    view = quat_to_matrix(q / np.linalg.norm(q))
    scene_in_world = camera_rot.T @ _CAMERA_FROM_VIEW @ view.T
    hand_in_scene = quat_to_matrix(np.asarray(hand_pose_in_world(grasp)[1], float))
    return scene_in_world @ hand_in_scene


def task_spec(r: Recognised, objects: tuple[int, ...], objects_xy: np.ndarray, hand: str = "barrett",
              camera_rot: np.ndarray | None = None) -> sim.TaskSpec:
    """The `sim.TaskSpec` of what was recognised (MAP §III).

    The recognised object among the scene's objects, the recognised grasp (a pointing: the grasp class
    of the object itself), the hand-over spot or the recognised place; the hand's orientation recognised
    with a transfer's grasp, turned into the world (`hand_rotation`) where `camera_rot` is given and the
    recogniser gave one, else the controller's canonical one.

    Args:
        r: what was recognised (`recognise_demo`), with a movement found.
        objects: the robot scene's objects (`sim.grasping.GRASP_OBJECTS` classes), one per row of
            `objects_xy`.
        objects_xy: (K, 2) where they stand, world m.
        hand: the robot hand ("barrett" or "karlsruhe").
        camera_rot: (3, 3) the world -> camera rotation of the view the grasp was recognised in
            (`camera_rotation`); None: the canonical orientation.

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
    recognised = r.kind == "transfer" and r.grasp in GRASP_CLASSES
    grasp = r.grasp if recognised else objects[r.target]
    oriented = recognised and camera_rot is not None and np.isfinite(np.asarray(r.grasp_quat, float)).all()
    hand_rot = hand_rotation(int(r.grasp), r.grasp_quat, camera_rot) if oriented else None
    return sim.TaskSpec(objects=tuple(objects), object_xy=objects_xy, target=int(r.target),
                        grasp=int(grasp), place_xy=np.asarray(r.place_xy, float), hand_rot=hand_rot, tactile=True,
                        hand=hand)


def robot_task(r: Recognised, objects: tuple[int, ...], objects_xy: np.ndarray, reach_phmm: P.PHMM | None = None,
               hand: str = "barrett", seed: int = 0, render: bool = False, area: TableArea = TableArea(),
               camera_rot: np.ndarray | None = None):
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
        camera_rot: as `task_spec`.

    Returns:
        The `sim.TaskResult`.

    Raises:
        ValueError: as `task_spec`.
    """
    spec = task_spec(r, objects, objects_xy, hand, camera_rot)
    path = synthesised_reach(reach_phmm, spec.object_xy[spec.target], area=area) if reach_phmm is not None else None
    return sim.run_task(spec, approach_path=path, seed=seed, options=sim.TaskOptions(render=render))
