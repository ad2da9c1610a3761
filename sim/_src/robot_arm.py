"""A HOAP-3-like robot arm at a table (PHMM, Humanoids 2008 §IV-B), as MJCF written here, and kinematic playback.

The arm: a fixed torso; a 3-DoF shoulder (hinges about -x, -y, -z of the shoulder frame {v_i}, in that
nested order, driven by the Cardan angles phi, theta, psi of `phmm_jax.retarget`); upper arm along
the local x; a 1-DoF elbow flexing about the local z; a 1-DoF wrist twist about the forearm; a simple
two-finger gripper opening along the twisted local z. Robot-sized limbs (HOAP-3 is about 60 cm tall):
upper arm 0.105 m, elbow to grasp point 0.145 m. World: x right, y forward, z up; the shoulder sits at
`SHOULDER_POS`; {v_i} = (down, forward, right), the arm's zero pose hangs down.

Playback sets the joint angles frame by frame and runs MuJoCo's forward kinematics and collision
detection: the grasp point (site "grasp") per frame, and the signed distance of every arm geom to the
table top (negative = the arm is inside the table).
"""
from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from lfd_common import as_array, check_real
from sim._src.scenes import checker_asset_xml

UPPER_ARM_M = 0.105
FOREARM_M = 0.145  # elbow to grasp point
SHOULDER_POS = np.array([0.0, 0.0, 0.45])
JOINTS = ("shoulder_phi", "shoulder_theta", "shoulder_psi", "elbow", "wrist_twist")
ARM_GEOMS = ("upper_arm", "elbow_cap", "forearm", "palm", "finger_a", "finger_b")


def arm_scene_xml(table_top_z: float, table_near_y: float = 0.05, targets: ArrayLike | None = None,
                  upper_arm: float = UPPER_ARM_M,
                  forearm: float = FOREARM_M) -> str:
    """MJCF of the HOAP-3-like robot (torso, 5-DoF arm, gripper) in front of a table (PHMM §IV).

    The table is a solid block down to the floor, so that an arm inside it is always found (a thin
    slab lets a capsule cross it undetected). A camera "side" and a camera "front" look at the
    workspace.

    Args:
        table_top_z: the table top's height (m, >= 0.01).
        table_near_y: the table's near edge, y (m).
        targets: (K, 3) points drawn as small discs on the table (visual only); None: none.
        upper_arm: the upper arm's length (m, >= 0.01).
        forearm: elbow to grasp point (m, >= 0.01).

    Returns:
        The MJCF text.

    Raises:
        ValueError: a length out of range or targets of the wrong shape.
    """
    table_top_z = check_real(table_top_z, "table_top_z", min_value=0.01)
    upper_arm = check_real(upper_arm, "upper_arm", min_value=0.01)
    forearm = check_real(forearm, "forearm", min_value=0.01)
    lower = forearm * 0.72  # elbow to wrist joint; the gripper covers the rest up to the grasp point
    reach = forearm - lower
    sx, sy, sz = SHOULDER_POS
    markers = ""
    if targets is not None:
        targets = as_array(targets, "targets", shape=(None, 3))
        markers = "\n".join(
            f'    <geom name="target{k}" type="cylinder" size="0.006 0.0005" pos="{t[0]:.4f} {t[1]:.4f} '
            f'{table_top_z + 0.0006:.4f}" rgba="0.9 0.2 0.2 1" contype="0" conaffinity="0"/>'
            for k, t in enumerate(targets))
    arm = 'contype="2" conaffinity="1"'
    return f"""<mujoco model="hoap3_like_arm">
  <compiler angle="radian"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  {checker_asset_xml("0.8 0.8 0.8", "0.7 0.7 0.7", texture_px=64)}
  <worldbody>
    <light pos="0.3 -0.5 1.5" dir="-0.2 0.4 -1"/>
    <geom name="floor" type="plane" size="1 1 0.01" material="grid" contype="0" conaffinity="0"/>
    <geom name="table" type="box" size="0.35 0.15 {table_top_z / 2:.4f}" pos="0 {table_near_y + 0.15:.4f} {table_top_z / 2:.4f}"
          rgba="0.6 0.45 0.3 1" contype="1" conaffinity="2"/>
{markers}
    <geom name="torso" type="box" size="0.06 0.045 0.1" pos="{sx - 0.075:.4f} {sy:.4f} {sz - 0.08:.4f}"
          rgba="0.75 0.75 0.8 1" contype="0" conaffinity="0"/>
    <geom name="head" type="sphere" size="0.045" pos="{sx - 0.075:.4f} {sy:.4f} {sz + 0.08:.4f}"
          rgba="0.75 0.75 0.8 1" contype="0" conaffinity="0"/>
    <camera name="side" pos="0.75 0.12 {sz + 0.1:.3f}" xyaxes="0 1 0 -0.15 0 1" fovy="45"/>
    <camera name="front" pos="0.05 0.75 {sz + 0.35:.3f}" xyaxes="-1 0 0 0 -0.45 1" fovy="50"/>
    <body name="shoulder_base" pos="{sx} {sy} {sz}" xyaxes="0 0 -1 0 1 0">
      <geom name="shoulder_cap" type="sphere" size="0.02" rgba="0.3 0.3 0.35 1" contype="0" conaffinity="0"/>
      <body name="shoulder_1">
        <joint name="shoulder_phi" type="hinge" axis="-1 0 0"/>
        <inertial pos="0 0 0" mass="0.02" diaginertia="1e-5 1e-5 1e-5"/>
        <body name="shoulder_2">
          <joint name="shoulder_theta" type="hinge" axis="0 -1 0"/>
          <inertial pos="0 0 0" mass="0.02" diaginertia="1e-5 1e-5 1e-5"/>
          <body name="upper_arm">
            <joint name="shoulder_psi" type="hinge" axis="0 0 -1"/>
            <geom name="upper_arm" type="capsule" fromto="0.02 0 0 {upper_arm - 0.015:.4f} 0 0" size="0.016"
                  rgba="0.85 0.85 0.9 1" {arm}/>
            <body name="forearm" pos="{upper_arm:.4f} 0 0">
              <joint name="elbow" type="hinge" axis="0 0 1"/>
              <geom name="elbow_cap" type="sphere" size="0.017" rgba="0.3 0.3 0.35 1" {arm}/>
              <geom name="forearm" type="capsule" fromto="0.015 0 0 {lower - 0.01:.4f} 0 0" size="0.014"
                    rgba="0.85 0.85 0.9 1" {arm}/>
              <body name="hand" pos="{lower:.4f} 0 0">
                <joint name="wrist_twist" type="hinge" axis="1 0 0"/>
                <geom name="palm" type="box" size="0.008 0.01 0.016" pos="0.006 0 0" rgba="0.3 0.3 0.35 1" {arm}/>
                <geom name="finger_a" type="box" size="{0.5 * (reach - 0.008):.4f} 0.004 0.003"
                      pos="{0.5 * (reach + 0.02):.4f} 0 0.011" rgba="0.2 0.2 0.25 1" {arm}/>
                <geom name="finger_b" type="box" size="{0.5 * (reach - 0.008):.4f} 0.004 0.003"
                      pos="{0.5 * (reach + 0.02):.4f} 0 -0.011" rgba="0.2 0.2 0.25 1" {arm}/>
                <site name="grasp" pos="{reach:.4f} 0 0" size="0.004" rgba="0 0.8 0 1"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


class Playback(NamedTuple):
    """The result of `play`: what the arm did, frame by frame.

    Attributes:
        grasp: (T, 3) grasp-point positions (world, m).
        elbow: (T, 3) elbow joint positions (world, m).
        table_distance: (T,) smallest signed distance (m) of any arm geom to the table (negative
            inside).
    """

    grasp: np.ndarray
    elbow: np.ndarray
    table_distance: np.ndarray


def joint_qpos(cardan, elbow, wrist) -> np.ndarray:
    """qpos (T, 5) in `JOINTS` order from Cardan angles (T, 3), elbow flexion (T,), wrist twist (T,)."""
    return np.concatenate([np.asarray(cardan, float), np.asarray(elbow, float)[:, None],
                           np.asarray(wrist, float)[:, None]], axis=1)


def play(model: mujoco.MjModel, qpos: ArrayLike) -> Playback:
    """Kinematic playback of a joint trajectory, with the arm's distance to the table.

    Args:
        model: the compiled arm scene (`arm_scene_xml`).
        qpos: (T, 5) joint angles (radians, `JOINTS` order: the Cardan angles phi, theta, psi of
            `phmm_jax.retarget`, the elbow, the wrist twist).

    Returns:
        The `Playback`.

    Raises:
        ValueError: qpos of the wrong shape or not finite.
    """
    qpos = as_array(qpos, "qpos", shape=(None, model.nq))
    data = mujoco.MjData(model)
    table = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "table")
    geoms = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in ARM_GEOMS]
    grasp_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "grasp")
    elbow_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "forearm")
    grasp, elbow, dist = [], [], []
    for q in qpos:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        grasp.append(data.site_xpos[grasp_id].copy())
        elbow.append(data.xpos[elbow_id].copy())
        dist.append(min(mujoco.mj_geomDistance(model, data, g, table, 0.5, None) for g in geoms))
    return Playback(np.array(grasp), np.array(elbow), np.array(dist))
