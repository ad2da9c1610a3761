"""lfd_jax.imitation.hand_rotation: the orientation GRASP eq. 4 recognises (the viewing frame of the
nearest database views) turned into the world, against the database's own cameras (`sphere_camera`,
which builds a view's camera independently of the conversion)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hog_jax import euler_to_quat
from lfd_common import quat_to_matrix
from lfd_jax.imitation import hand_rotation
from sim.grasping import GRASP_CLASSES, sphere_camera, view_euler
from sim.hands import hand_pose_in_world

FLIP_TO_OPENCV = np.diag([1.0, -1.0, -1.0])   # MuJoCo camera axes (y up, z backwards) -> (y down, z forward)


def database_view(az: float, el: float, roll: float, world_from_scene: np.ndarray = np.eye(3)):
    """(recognised quaternion, world -> camera rotation) of the database view (az, el, roll) of a grasp
    scene standing in the world turned by `world_from_scene`."""
    _, scene_from_camera = sphere_camera(az, el, 0.5, roll)
    world_from_camera = world_from_scene @ scene_from_camera @ FLIP_TO_OPENCV
    quat = np.asarray(euler_to_quat(view_euler(az, el, roll)), float)
    return quat, world_from_camera.T


def yaw(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@settings(max_examples=40, deadline=None)
@given(grasp=st.sampled_from(GRASP_CLASSES), az=st.floats(-180, 180), el=st.floats(-80, 80),
       roll=st.floats(-30, 30), turn=st.floats(-np.pi, np.pi))
def test_a_database_view_gives_back_the_hand_of_its_scene(grasp, az, el, roll, turn):
    hand_in_scene = quat_to_matrix(np.asarray(hand_pose_in_world(grasp)[1], float))
    quat, camera_rot = database_view(az, el, roll, yaw(turn))
    np.testing.assert_allclose(hand_rotation(grasp, quat, camera_rot), yaw(turn) @ hand_in_scene, atol=1e-6)


def test_the_camera_matters():
    # the same recognised view from a camera turned 90 degrees about the vertical: the hand turns with it
    quat, camera_rot = database_view(30.0, 20.0, 0.0)
    turned = hand_rotation(1, quat, camera_rot @ yaw(np.pi / 2).T)
    np.testing.assert_allclose(turned, yaw(np.pi / 2) @ hand_rotation(1, quat, camera_rot), atol=1e-12)
    assert np.abs(turned - hand_rotation(1, quat, camera_rot)).max() > 0.5


@pytest.mark.parametrize("kwargs, name", [
    (dict(grasp=3), "grasp"), (dict(view_quat=np.full(4, np.nan)), "view_quat"), (dict(view_quat=np.zeros(4)), "view_quat"),
    (dict(view_quat=np.ones(3)), "view_quat"), (dict(camera_rot=2 * np.eye(3)), "camera_rot"),
    (dict(camera_rot=np.diag([1.0, 1.0, -1.0])), "camera_rot"), (dict(camera_rot=np.eye(4)), "camera_rot")])
def test_bad_input_names_the_argument(kwargs, name):
    args = dict(grasp=1, view_quat=np.array([1.0, 0.0, 0.0, 0.0]), camera_rot=np.eye(3)) | kwargs
    with pytest.raises(ValueError, match=name):
        hand_rotation(**args)
