"""The motion half of the robot's task controller (`run_task` runs it): one MuJoCo world stepped by
control periods (`TaskSim`: palm pose -> tracking IK -> the arm's servo targets, the grasp study's
sensors read per period; `MjxTaskSim`: the same with the physics on MJX-JAX), moves along the palm's
paths (`sim._src.task_plan.pose_path`), holds, and the geometry of standing a held object upright."""
from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from sim._src.grasp_rollout import SUBSTEPS, peak_touch
from sim._src.mjx_compat import contact_distances, contact_geoms
from sim._src.rollout import mjx_step
from sim._src.grasp_strategy import CONTROL_DT_S
from sim._src.manipulator import HOME_Q, manipulator_qpos
from sim._src.render import setup_rendering
from sim._src.robot_hands import SceneLayout
from sim._src.task_plan import TaskOptions, TaskScene, TaskSpec, pose_path, task_scene, track_ik


class TaskSim:
    """One native MuJoCo world of a task, stepped by control periods: palm pose -> tracking IK -> arm servos.

    Every palm pose becomes arm joint targets by one step of the tracking IK (`track_ik`: damped least
    squares, one start, warm-started at the last target); the grasp study's sensors are read per
    control period (`sim.grasping.peak_touch`). The arm starts at `HOME_Q`.

    Args:
        scene: the task's scene (`task_scene`).
        spec: the task (checked).
        open_: (D,) the hand's starting targets (the open preshape).
        options: `options.render`, `camera`, `width`, `height` and `fps` set the recorded video
            (`TaskOptions`).
    """

    def __init__(self, scene: TaskScene, spec: TaskSpec, open_: np.ndarray, options: TaskOptions = TaskOptions()):
        render, camera, width, height, fps = (options.render, options.camera, options.width, options.height,
                                              options.fps)
        self.scene, self.model = scene, scene.model
        self.data = mujoco.MjData(self.model)
        arm = scene.arm
        self.data.qpos[:] = _start_qpos(scene, open_)
        self.q_cmd = HOME_Q.astype(float).copy()
        self.data.ctrl[arm.arm_ctrl] = self.q_cmd
        self.data.ctrl[arm.hand_ctrl] = open_
        mujoco.mj_forward(self.model, self.data)
        self.sensordata = self.data.sensordata[None].copy()
        self.target = spec.target
        self.others = [b for k, b in enumerate(arm.object_body) if k != spec.target]
        self.others_start = self.data.xpos[self.others].copy()
        self.obj_geom = self.model.body_geomadr[arm.object_body[spec.target]]
        self.t = 0.0
        self.frames, self.renderer = [], None
        if render:
            setup_rendering()
            self.renderer = mujoco.Renderer(self.model, height=height, width=width)
            self.camera, self.frame_dt, self.next_frame = camera, 1.0 / fps, 0.0
            self._grab()

    def _grab(self):
        self.renderer.update_scene(self.data, camera=self.camera)
        self.frames.append(self.renderer.render().copy())
        self.next_frame += self.frame_dt

    def step(self, pos: np.ndarray, rot: np.ndarray, fingers: np.ndarray) -> None:
        """One control period with the palm commanded to a pose and the hand to targets.

        Args:
            pos: (3,) the palm's position (world m).
            rot: (3, 3) its rotation.
            fingers: (D,) the hand's targets.
        """
        self.q_cmd = np.asarray(track_ik(self.scene.chain, self.q_cmd[None], pos[None], rot[None]).q[0], float)
        self._step(fingers)

    def _step(self, fingers: np.ndarray) -> None:
        """One control period with the arm's servos at `q_cmd` and the hand's at fingers (D,)."""
        arm = self.scene.arm
        self.data.ctrl[arm.arm_ctrl] = self.q_cmd
        self.data.ctrl[arm.hand_ctrl] = fingers
        self.sensordata = peak_touch(self._substeps()[None], self.scene.sensors)
        self.t += CONTROL_DT_S
        if self.renderer is not None and self.t >= self.next_frame - 1e-9:
            self._grab()

    def _substeps(self) -> np.ndarray:
        """The physics of one control period at `data.ctrl`: (SUBSTEPS, S) sensordata of each substep."""
        record = np.empty((SUBSTEPS, self.model.nsensordata))
        for k in range(SUBSTEPS):
            mujoco.mj_step(self.model, self.data)
            record[k] = self.data.sensordata
        return record

    def palm(self) -> np.ndarray:
        """The palm centre's position now.

        Returns:
            (3,) world m.
        """
        return self.data.site_xpos[self.scene.arm.palm_site].copy()

    def hand_q(self) -> np.ndarray:
        """The hand's actuated joint positions now.

        Returns:
            (D,) radians, `HandSpec.dofs` order.
        """
        return self.data.actuator_length[self.scene.arm.hand_ctrl].copy()

    def obj_pos(self) -> np.ndarray:
        """The handled object's position now.

        Returns:
            (3,) world m.
        """
        return self.data.xpos[self.scene.arm.object_body[self.target]].copy()

    def others_moved(self) -> float:
        """How far the objects other than the handled one have moved since the start, the most.

        Returns:
            The largest x-y displacement (m); 0 without other objects.
        """
        if not self.others:
            return 0.0
        return float(np.max(np.linalg.norm(self.data.xpos[self.others, :2] - self.others_start[:, :2], axis=1)))

    def obj_rot(self) -> np.ndarray:
        """The handled object's rotation now.

        Returns:
            (3, 3) rotation matrix (columns: its axes in the world).
        """
        return self.data.xmat[self.scene.arm.object_body[self.target]].reshape(3, 3).copy()

    def _pairs(self) -> np.ndarray:
        c = self.data.contact
        n = self.data.ncon
        return np.stack([c.geom1[:n], c.geom2[:n]], -1) if n else np.zeros((0, 2), int)

    def contact(self, geoms_a: ArrayLike, geoms_b: ArrayLike) -> bool:
        """Whether any geom of `geoms_a` touches any of `geoms_b` now.

        Args:
            geoms_a: geom ids.
            geoms_b: geom ids.

        Returns:
            True if some contact pairs one of each.
        """
        pairs = self._pairs()
        a, b = np.isin(pairs, geoms_a), np.isin(pairs, geoms_b)
        return bool(np.any((a[:, 0] & b[:, 1]) | (a[:, 1] & b[:, 0])))

    def touches(self, geoms: ArrayLike) -> bool:
        """Whether the handled object touches any of `geoms` now.

        Args:
            geoms: geom ids.

        Returns:
            True if it does.
        """
        return self.contact([self.obj_geom], geoms)

    def close(self) -> None:
        """Free the renderer's GL context, if there is one."""
        if self.renderer is not None:
            self.renderer.close()


# XLA:CPU's default fusion emitters (jaxlib 0.10.2) compile MJX's kinematics of the manipulator scene
# into code that ran for more than 100 s (killed) where the loop-fusion emitter's runs in 3 ms; the grasp
# scene (a floating hand) is not affected. A per-program option, so the rest of the process keeps its
# flags (other back ends ignore it).
_MJX_COMPILER_OPTIONS = {"xla_cpu_use_fusion_emitters": False}


class _MjxReads(NamedTuple):
    """What the controller reads after a control period, copied to the host (float32, one world)."""

    qpos: jax.Array             # (nq,)
    qvel: jax.Array             # (nv,)
    xpos: jax.Array             # (nbody, 3)
    xmat: jax.Array             # (nbody, 9)
    site_xpos: jax.Array        # (nsite, 3)
    actuator_length: jax.Array  # (nu,)
    pairs: jax.Array            # (ncon, 2) int: geom ids of each candidate contact, -1 where it does not touch


@functools.partial(jax.jit, compiler_options=_MJX_COMPILER_OPTIONS)
def _mjx_period(mjx_model: mjx.Model, data: mjx.Data, ctrl: jax.Array) -> tuple[mjx.Data, jax.Array, _MjxReads]:
    """One control period on MJX-JAX: `SUBSTEPS` `mjx_step`s at ctrl (nu,); (data, (SUBSTEPS, S)
    sensordata of each substep, the reads). A contact touches at distance <= 0, as MuJoCo keeps it
    (no geom margins in the manipulator scene)."""
    def substep(d, _):
        d = mjx_step(mjx_model, d)
        return d, d.sensordata

    data, record = jax.lax.scan(substep, data.replace(ctrl=ctrl), None, length=SUBSTEPS)
    pairs = jnp.where((contact_distances(data) <= 0)[:, None], contact_geoms(data), -1)
    reads = _MjxReads(data.qpos, data.qvel, data.xpos, data.xmat.reshape(-1, 9), data.site_xpos,
                      data.actuator_length, pairs)
    return data, record, reads


@functools.lru_cache(maxsize=8)
def _mjx_model(hand: str, objects: tuple[int, ...], object_xy: tuple[tuple[float, float], ...]) -> mjx.Model:
    """The task scene (`task_scene`, same arguments) on MJX-JAX, committed to the default device (a
    second task then reuses the compiled period: placements change only the model's arrays, not its
    static structure).

    Raises:
        ValueError: a scene with a geom pair MJX-JAX cannot collide, naming `backend`.
    """
    try:
        model = mjx.put_model(task_scene(hand, objects, object_xy).model, impl="jax")
    except NotImplementedError as err:
        raise ValueError(f"backend: 'mjx-jax' cannot simulate this scene ({err}; the arm's cylinders and "
                         "the Pinch cube, class 9); use 'native'") from err
    return jax.device_put(model, jax.devices()[0])


class MjxTaskSim(TaskSim):
    """`TaskSim` with the physics on MJX-JAX: the same start, controller, IK and reads.

    Each control period is one jitted program (`_mjx_period`: a `lax.scan` of `SUBSTEPS` `mjx_step`s
    recording sensordata, compiled once per hand and object classes). After it, the state the
    controller reads (qpos, qvel, body and site poses, actuator lengths) is copied into `data`, and the
    contacts from MJX's candidate contacts (touching at distance <= 0, as `TaskSim.contact`); the full
    state is copied into `data` (`mjx.get_data_into`) only to render a frame.

    Args:
        scene: the task's scene (`task_scene`).
        spec: the task (checked).
        open_: (D,) the hand's starting targets (the open preshape).
        options: as `TaskSim`'s.

    Raises:
        ValueError: a scene MJX-JAX cannot simulate (`backend`).
    """

    mjx_data = None   # until the start is on the device: frames come from `data` itself

    def __init__(self, scene: TaskScene, spec: TaskSpec, open_: np.ndarray, options: TaskOptions = TaskOptions()):
        self.mjx_model = _mjx_model(spec.hand, spec.objects, tuple(map(tuple, np.asarray(spec.object_xy).tolist())))
        super().__init__(scene, spec, open_, options)
        self.device = jax.devices()[0]
        self.mjx_data = jax.device_put(mjx.put_data(self.model, self.data, impl="jax"), self.device)
        self.pairs = super()._pairs()   # the start: MuJoCo's forward pass of the same state

    def _substeps(self) -> np.ndarray:
        ctrl = jax.device_put(jnp.asarray(self.data.ctrl, jnp.float32), self.device)
        self.mjx_data, record, reads = _mjx_period(self.mjx_model, self.mjx_data, ctrl)
        record, reads = jax.device_get((record, reads))
        for name in ("qpos", "qvel", "xpos", "xmat", "site_xpos", "actuator_length"):
            getattr(self.data, name)[:] = getattr(reads, name)
        self.pairs = reads.pairs[reads.pairs[:, 0] >= 0]
        return np.asarray(record, np.float64)

    def _pairs(self) -> np.ndarray:
        return self.pairs

    def _grab(self):
        if self.mjx_data is not None:
            mjx.get_data_into(self.data, self.model, self.mjx_data)
        super()._grab()


def task_sim(scene: TaskScene, spec: TaskSpec, open_: np.ndarray, options: TaskOptions = TaskOptions()) -> TaskSim:
    """The world of a task on `options.backend`: a `TaskSim` ("native") or an `MjxTaskSim` ("mjx-jax").

    Args:
        scene: the task's scene (`task_scene`).
        spec: the task (checked).
        open_: (D,) the hand's starting targets.
        options: the backend and the video (`TaskOptions`).

    Returns:
        The world, at the start.
    """
    cls = MjxTaskSim if options.backend == "mjx-jax" else TaskSim
    return cls(scene, spec, open_, options)


def _start_qpos(scene: TaskScene, open_: np.ndarray) -> np.ndarray:
    return manipulator_qpos(scene.model, scene.arm, HOME_Q, open_)


def move(sim: TaskSim, points: np.ndarray, rot_from: np.ndarray, rot_to: np.ndarray, fingers, speed: float):
    for p, r in zip(*pose_path(points, rot_from, rot_to, speed)):
        sim.step(p, r, fingers)


def upright_axis(obj, rot: np.ndarray) -> np.ndarray:
    """The object axis (3,) that should stand vertical: its z axis; for a cube, whichever of its axes
    (signed) is nearest to the vertical (a cube stands on any face)."""
    if obj.geom_type == "box" and np.ptp(obj.size) < 1e-9:
        k = int(np.argmax(np.abs(rot[2])))
        return rot[:, k] * np.sign(rot[2, k])
    return rot[:, 2]


def object_tilt(obj, rot: np.ndarray) -> float:
    """How far (rad) the object with rotation `rot` (3, 3) is from standing upright (0 for a ball)."""
    if obj.geom_type == "sphere":
        return 0.0
    return float(np.arccos(np.clip(upright_axis(obj, rot)[2], -1.0, 1.0)))


def tilt_correction(axis: np.ndarray) -> np.ndarray:
    """(3, 3) the smallest rotation that turns the unit vector `axis` (3,) to the vertical."""
    k = np.cross(axis, [0.0, 0.0, 1.0])
    angle = np.arctan2(np.linalg.norm(k), axis[2])
    if np.linalg.norm(k) < 1e-9:
        return np.eye(3)
    return Rotation.from_rotvec(k / np.linalg.norm(k) * angle).as_matrix()


def hold(sim: TaskSim, pos, rot, fingers, seconds: float):
    for _ in range(int(round(seconds / CONTROL_DT_S))):
        sim.step(pos, rot, fingers)


def ramp_fingers(sim: TaskSim, pos, rot, start: np.ndarray, end: np.ndarray, seconds: float):
    """The hand's targets linearly from start (D,) to end (D,) over `seconds`, the palm held at (pos, rot)."""
    for s in np.linspace(0.0, 1.0, int(round(seconds / CONTROL_DT_S)) + 1)[1:]:
        sim.step(pos, rot, start + s * (end - start))


def held_links(sensordata: np.ndarray, sensors: SceneLayout, target: int) -> int:
    return int(np.sum(sensordata[0, sensors.contact[:, target]] > 0))
