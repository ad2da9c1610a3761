"""A rectified stereo camera pair: projection, triangulation and camera matrices (LfD 2009 §III-A: the
hand and face centroids of both views give the hand-minus-face position in 3-D).

Frames: points are in the *left camera frame* (metres): x to the image's right, y down, z along the
optical axis. The right camera is the left one moved by `baseline_m` along +x (a rectified pair: the
same intrinsics, parallel optical axes), so a point (X, Y, Z) has the right-camera coordinates
(X - b, Y, Z). Pixels are (x, y) = (column, row) with pixel centres at integer coordinates (the
convention of `blobs`); the principal point defaults to the image centre ((W - 1) / 2,
(H - 1) / 2) in that convention, which is where a MuJoCo/OpenGL camera puts its optical axis.

    x = f X / Z + cx,    y = f Y / Z + cy,    x_right = x - f b / Z        (disparity d = f b / Z)
    Z = f b / d,         X = (x - cx) Z / f,  Y = (y - cy) Z / f           (y of the left image)

Arrays: NumPy input is computed in float64 NumPy (exact, for the data generators); a `jax.Array`
input (also inside `jit`/`vmap`) is computed with `jax.numpy` in its own dtype. Concrete inputs are
checked (shape (..., 2) or (..., 3), finite) and a ValueError names the argument.
"Not found" is a flag, never a clamp: a point with Z <= 0 has `in_front` False (its pixels are 0), a
pixel pair with disparity <= 0 (or a non-finite one under `jit`) has `valid` False (its point is 0).
"""
from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import cv2
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Real

from lfd_common import as_array, check_int, check_real

__all__ = ["StereoCamera", "StereoProjection", "Triangulation", "camera_matrices", "project",
           "stereo_camera_from_matrices", "triangulate"]


@dataclasses.dataclass(frozen=True)
class StereoCamera:
    """A rectified stereo camera pair (LfD 2009 §III-A: the hand-minus-face position in 3-D).

    Points are in the left camera frame (metres): x to the image's right, y down, z along the optical
    axis; the right camera is the left one moved by `baseline_m` along +x (the same intrinsics,
    parallel optical axes). Pixels are (x, y) = (column, row), pixel centres at integer coordinates:
    x = f X / Z + cx, y = f Y / Z + cy, x_right = x - f b / Z (disparity d = f b / Z).

    Attributes:
        focal_px: the focal length f, pixels, > 0.
        baseline_m: the baseline b, metres, > 0 (the right camera at +x).
        width: the image width W, pixels, >= 1.
        height: the image height H, pixels, >= 1.
        cx: the principal point's x, pixels (default the image centre (W - 1) / 2, where a
            MuJoCo/OpenGL camera puts its optical axis).
        cy: the principal point's y, pixels (default (H - 1) / 2).

    Raises:
        ValueError: naming the field for a non-positive focal length, baseline or size, or a
            non-finite principal point.
    """

    focal_px: float
    baseline_m: float
    width: int
    height: int
    cx: float | None = None
    cy: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "focal_px", check_real(self.focal_px, "focal_px", min_value=0.0, exclusive_min=True))
        object.__setattr__(self, "baseline_m",
                           check_real(self.baseline_m, "baseline_m", min_value=0.0, exclusive_min=True))
        object.__setattr__(self, "width", check_int(self.width, "width", min_value=1))
        object.__setattr__(self, "height", check_int(self.height, "height", min_value=1))
        for name, size in (("cx", self.width), ("cy", self.height)):
            value = (size - 1) / 2.0 if getattr(self, name) is None else check_real(getattr(self, name), name)
            object.__setattr__(self, name, value)

    @classmethod
    def from_fovy(cls, fovy_deg: float, width: int, height: int, baseline_m: float) -> StereoCamera:
        """The pair of two cameras with MuJoCo's vertical field of view `fovy_deg`: f = (H / 2) / tan(fovy / 2)."""
        fovy = check_real(fovy_deg, "fovy_deg", min_value=0.0, max_value=179.0, exclusive_min=True)
        height = check_int(height, "height", min_value=1)
        return cls(0.5 * height / math.tan(math.radians(fovy) / 2.0), baseline_m, width, height)


class StereoProjection(NamedTuple):
    """Pixels of points in both views (`project`).

    Attributes:
        left: (..., 2) pixels (x, y) in the left image.
        right: (..., 2) pixels (x, y) in the right image.
        in_front: (...) bool, False for Z <= 0 (pixels 0 there).
    """

    left: Float[Array, "*batch 2"]
    right: Float[Array, "*batch 2"]
    in_front: Bool[Array, "*batch"]


class Triangulation(NamedTuple):
    """Points from matching pixels of both views (`triangulate`).

    Attributes:
        xyz: (..., 3) metres in the left camera frame.
        valid: (...) bool, False for disparity <= 0 (xyz 0 there).
    """

    xyz: Float[Array, "*batch 3"]
    valid: Bool[Array, "*batch"]


def _namespace(name: str, value, last: int):
    """(array, xp): NumPy float64 for host input, jax.numpy for a jax.Array; concrete input is checked."""
    if isinstance(value, jax.core.Tracer):
        if value.ndim < 1 or value.shape[-1] != last:
            raise ValueError(f"{name}: expected shape (..., {last}), got {value.shape}")
        return value, jnp
    checked = as_array(value, name, dtype=np.float64, nonempty=False)
    if checked.ndim < 1 or checked.shape[-1] != last:
        raise ValueError(f"{name}: expected shape (..., {last}), got {checked.shape}")
    if isinstance(value, jax.Array):
        return value, jnp
    return checked, np


def project(camera: StereoCamera, points: Float[ArrayLike, "*batch 3"]) -> StereoProjection:
    """Pixels of points in both views of a rectified pair (LfD 2009 §III-A).

    NumPy input is computed in float64 NumPy; a `jax.Array` (also inside `jit` / `vmap`) with
    `jax.numpy` in its own dtype. "Not found" is a flag, never a clamp.

    Args:
        camera: the `StereoCamera`.
        points: (..., 3) points in the left camera frame, metres.

    Returns:
        A `StereoProjection`: left and right pixels (..., 2) and in_front (...).

    Raises:
        ValueError: `points` of a shape other than (..., 3), or not finite (concrete input).
    """
    p, xp = _namespace("points", points, 3)
    z = p[..., 2]
    in_front = z > 0
    safe_z = xp.where(in_front, z, 1.0)  # double where: no inf/NaN even in the discarded branch
    x = xp.where(in_front, camera.focal_px * p[..., 0] / safe_z + camera.cx, 0.0)
    y = xp.where(in_front, camera.focal_px * p[..., 1] / safe_z + camera.cy, 0.0)
    shift = xp.where(in_front, camera.focal_px * camera.baseline_m / safe_z, 0.0)
    return StereoProjection(xp.stack([x, y], axis=-1), xp.stack([x - shift, y], axis=-1), in_front)


def triangulate(camera: StereoCamera, left_px: Float[ArrayLike, "*batch 2"],
                right_px: Float[ArrayLike, "*batch 2"]) -> Triangulation:
    """Points in the left camera frame from matching pixels of both views (LfD 2009 §III-A).

    Depth from the disparity d = x_left - x_right (Z = f b / d), X and Y from the left pixel (the
    rows of a rectified pair agree; the right row is not used): Z = f b / d, X = (x - cx) Z / f,
    Y = (y - cy) Z / f. d <= 0 (behind the cameras or a wrong match), or one so small that the depth
    overflows, gives `valid` False and xyz 0: never a clamped depth.

    Args:
        camera: the `StereoCamera`.
        left_px: (..., 2) pixels (x, y) in the left image.
        right_px: (..., 2) matching pixels in the right image.

    Returns:
        A `Triangulation`: xyz (..., 3) and valid (...).

    Raises:
        ValueError: naming the argument for pixels of a shape other than (..., 2), not finite
            (concrete input), or of different shapes (`right_px`).
    """
    left, xp = _namespace("left_px", left_px, 2)
    right, xp_right = _namespace("right_px", right_px, 2)
    if xp_right is jnp:
        xp = jnp
    if left.shape != right.shape:
        raise ValueError(f"right_px: expected the shape of left_px {left.shape}, got {right.shape}")
    disparity = left[..., 0] - right[..., 0]
    positive = disparity > 0  # False for NaN too
    with np.errstate(over="ignore"):  # a subnormal disparity overflows the depth: flagged below
        z = camera.focal_px * camera.baseline_m / xp.where(positive, disparity, 1.0)
        scale = z / camera.focal_px
        xyz = xp.stack([(left[..., 0] - camera.cx) * scale, (left[..., 1] - camera.cy) * scale, z], axis=-1)
    valid = positive & xp.all(xp.isfinite(xyz), axis=-1)
    return Triangulation(xp.where(valid[..., None], xyz, 0.0), valid)


def camera_matrices(camera: StereoCamera) -> tuple[np.ndarray, np.ndarray]:
    """The 3 x 4 projection matrices of the left and right camera (OpenCV's `P1`, `P2` convention).

    K [I | 0] and K [I | -b e_x], mapping homogeneous left-camera-frame points to homogeneous pixels.

    Args:
        camera: the `StereoCamera`.

    Returns:
        (left, right), float64 (3, 4) arrays.
    """
    K = np.array([[camera.focal_px, 0.0, camera.cx], [0.0, camera.focal_px, camera.cy], [0.0, 0.0, 1.0]])
    left = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
    right = K @ np.hstack([np.eye(3), np.array([[-camera.baseline_m], [0.0], [0.0]])])
    return left, right


def stereo_camera_from_matrices(P_left: Real[ArrayLike, "3 4"], P_right: Real[ArrayLike, "3 4"], height: int,
                                width: int) -> StereoCamera:
    """The rectified pair of two 3 x 4 camera matrices (world -> pixels), the inverse of `camera_matrices`.

    The intrinsics come from the left matrix and the two camera centres from both
    (`cv2.decomposeProjectionMatrix`, K normalised to K[2, 2] = 1); the baseline is the centres'
    distance. The pair is taken to be rectified (the same intrinsics and orientation, the right camera
    along the left one's +x, as `StereoCamera` assumes); that is checked to 1e-6 relative.

    Args:
        P_left: (3, 4) the left camera's matrix, pixel centres at integer coordinates.
        P_right: (3, 4) the right camera's matrix.
        height: the image height H, pixels, >= 1.
        width: the image width W, pixels, >= 1.

    Returns:
        The `StereoCamera` (focal length, baseline, principal point and image size).

    Raises:
        ValueError: naming the argument for a matrix that is not a finite (3, 4) array or has no finite
            camera centre, a right matrix whose camera is not the left one moved along its x axis, or
            a size < 1.
    """
    P_left = as_array(P_left, "P_left", shape=(3, 4))
    P_right = as_array(P_right, "P_right", shape=(3, 4))
    height = check_int(height, "height", min_value=1)
    width = check_int(width, "width", min_value=1)
    for name, P in (("P_left", P_left), ("P_right", P_right)):
        if abs(np.linalg.det(P[:, :3])) <= 1e-12 * max(np.abs(P[:, :3]).max(), 1e-300) ** 3:
            raise ValueError(f"{name}: its left 3 x 3 block is singular (no finite camera centre)")
    K, _, left_centre = cv2.decomposeProjectionMatrix(P_left)[:3]
    right_centre = cv2.decomposeProjectionMatrix(P_right)[2]
    baseline = np.linalg.norm(left_centre[:3, 0] / left_centre[3, 0] - right_centre[:3, 0] / right_centre[3, 0])
    _check_rectified(P_left, P_right, K, float(baseline))
    K = K / K[2, 2]
    return StereoCamera(focal_px=float(K[0, 0]), baseline_m=float(baseline), width=width, height=height,
                        cx=float(K[0, 2]), cy=float(K[1, 2]))


def _check_rectified(P_left: np.ndarray, P_right: np.ndarray, K: np.ndarray, baseline: float) -> None:
    """Raise unless P_right (up to scale) is P_left = K [R | t] moved by `baseline` along the left camera's
    x axis: K [R | t - b e_x]."""
    expected = P_left.copy()
    expected[:, 3] -= baseline * K[:, 0]
    scale = np.sum(P_right * expected) / np.sum(expected * expected)
    if not np.allclose(P_right / scale, expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max()):
        raise ValueError("P_right: expected the left camera moved along its x axis (a rectified pair), got another "
                         "camera")
