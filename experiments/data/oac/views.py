"""Rendering a recording: hand and object views, skin segmentation, blur, HOG."""
from __future__ import annotations

import math

import numpy as np

from experiments.data.oac.settings import OACSettings, Person
from experiments.data.oac.motion import face_point, camera_pose, measured_positions, object_trajectory
from experiments.data.oac.scene import rotation_to_quat, grip_of, scene_xml


# ---------------------------------------------------------------------------------------- rendering
class Views:
    """MuJoCo offscreen views of one (class, person) scene: square crops aimed from the left camera."""

    def __init__(self, cls: int, person: Person, image_px: int):
        import mujoco

        self.model = mujoco.MjModel.from_xml_string(scene_xml(cls, person, image_px))
        self.data = mujoco.MjData(self.model)
        self.renderer = mujoco.Renderer(self.model, image_px, image_px)
        hand = self.model.body("hand").id
        obj = self.model.body("object").id
        parents = self.model.body_parentid
        in_hand = np.zeros(self.model.nbody, bool)
        for b in range(self.model.nbody):  # bodies are ordered parents first
            in_hand[b] = b == hand or (b > 0 and in_hand[parents[b]])
        body = self.model.geom_bodyid
        self.hand_geoms = np.flatnonzero(in_hand[body])
        # geom label: 0 nothing, 1 hand, 2 object, 3 head; index -1 (background) maps to 0 (the extra slot)
        self.label = np.zeros(self.model.ngeom + 1, np.int8)
        self.label[self.hand_geoms] = 1
        self.label[np.flatnonzero(body == obj)] = 2
        self.label[np.flatnonzero(body == self.model.body("head").id)] = 3
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE

    def pose(self, pos: np.ndarray, rot: np.ndarray, qpos: np.ndarray) -> np.ndarray:
        """Place the grasped part at (pos, rot); return the hand centre (3,) (mean of its geom centres)."""
        import mujoco

        self.data.qpos[:] = qpos
        self.data.mocap_pos[0] = pos
        self.data.mocap_quat[0] = rotation_to_quat(rot)
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.geom_xpos[self.hand_geoms].mean(axis=0)

    def render(self, eye: np.ndarray, lookat: np.ndarray, half_extent_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Grey image (P, P) in [0, 1] and labels (P, P) (0 none, 1 hand, 2 object, 3 head) of a view from
        `eye` towards `lookat` whose half field of view spans `half_extent_m` at the lookat distance."""
        offset = lookat - eye
        dist = float(np.linalg.norm(offset))
        self.camera.lookat[:] = lookat
        self.camera.distance = dist
        self.camera.azimuth = math.degrees(math.atan2(offset[1], offset[0]))
        self.camera.elevation = math.degrees(math.asin(offset[2] / dist))
        self.model.vis.global_.fovy = math.degrees(2 * math.atan(half_extent_m / dist))
        self.renderer.update_scene(self.data, camera=self.camera)
        rgb = self.renderer.render()
        self.renderer.enable_segmentation_rendering()
        self.renderer.update_scene(self.data, camera=self.camera)
        seg = self.renderer.render()
        self.renderer.disable_segmentation_rendering()
        geom = np.where(seg[..., 1] == 5, seg[..., 0], -1)  # mjOBJ_GEOM == 5
        return rgb.mean(axis=-1) / 255.0, self.label[geom]

    def close(self):
        self.renderer.close()


def _crop_square(image: np.ndarray, box: tuple[int, int, int, int], size: int) -> np.ndarray:
    """Cut rows box[0]:box[1], columns box[2]:box[3] (zero outside the image) and rescale to size x size
    (aspect normalised, §5)."""
    import cv2

    r0, r1, c0, c1 = box
    pad = max(0, -r0, -c0, r1 - image.shape[0], c1 - image.shape[1])
    padded = np.pad(np.asarray(image, np.float32), pad)
    cut = padded[r0 + pad:r1 + pad, c0 + pad:c1 + pad]
    return cv2.resize(np.ascontiguousarray(cut), (size, size), interpolation=cv2.INTER_AREA)


def _square_box(mask: np.ndarray) -> tuple[int, int, int, int]:
    """The square around the mask's bounding box (may extend past the image; `_crop_square` pads)."""
    r0, r1, c0, c1 = _bbox(mask)
    side = max(r1 - r0, c1 - c0)
    r, c = (r0 + r1 - side) // 2, (c0 + c1 - side) // 2
    return r, r + side, c, c + side


def _jitter_mask(mask: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Skin-segmentation boundary error: the mask eroded or dilated by one pixel, or unchanged (1/3 each)."""
    import cv2

    kind = rng.integers(3)
    if kind == 2:
        return mask
    op = cv2.erode if kind == 0 else cv2.dilate
    out = op(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    return out if out.any() else mask


def _bbox(mask: np.ndarray, margin: int = 1) -> tuple[int, int, int, int]:
    """Bounding box (r0, r1, c0, c1) of a boolean mask, grown by `margin`; the whole image if empty."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return 0, mask.shape[0], 0, mask.shape[1]
    h, w = mask.shape
    return (max(rows[0] - margin, 0), min(rows[-1] + 1 + margin, h),
            max(cols[0] - margin, 0), min(cols[-1] + 1 + margin, w))


def skin_segment(label: np.ndarray) -> np.ndarray:
    """The hand mask a skin-colour segmentation gives: the skin pixels (hand and face, labels 1 and 3)
    connected to the hand; when the hand touches the face in the image, the face joins the mask."""
    import cv2

    skin = ((label == 1) | (label == 3)).astype(np.uint8)
    _, comp = cv2.connectedComponents(skin, connectivity=8)
    keep = np.unique(comp[label == 1])
    return np.isin(comp, keep[keep > 0])


def _motion_blur(image: np.ndarray, shift_px: np.ndarray) -> np.ndarray:
    """Average of `image` over a straight motion of `shift_px` (2,) pixels (x right, y down)."""
    import cv2

    steps = int(np.ceil(np.hypot(*shift_px)))
    if steps < 1:
        return image.astype(np.float32)
    size = 2 * steps + 1
    kernel = np.zeros((size, size), np.float32)
    for f in np.linspace(-0.5, 0.5, 2 * steps + 1):
        kernel[int(round(steps + f * shift_px[1])), int(round(steps + f * shift_px[0]))] += 1.0
    return cv2.filter2D(image.astype(np.float32), -1, kernel / kernel.sum(), borderType=cv2.BORDER_CONSTANT)


def record(views: Views, cls: int, person: Person, rng: np.random.Generator, settings: OACSettings) -> dict:
    """Render one recording: hand and object images (T, P, P) / (T, S, S) with masks, positions, T."""
    from sim.hands import GRASP_POSTURES
    from sim.hands import clip_posture, posture_qpos

    duration = settings.duration_s / person.speed * (1.0 + 0.08 * rng.standard_normal())
    n = max(int(round(duration * settings.fps)), 8)
    pos, rots = object_trajectory(cls, person, rng, n)
    grip = grip_of(cls, person)
    joints = clip_posture(np.asarray(GRASP_POSTURES[grip.grasp].joints_deg) + 4.0 * rng.standard_normal(20))
    qpos = posture_qpos(joints)
    eye, cam_rot = camera_pose(person)
    px, so = settings.image_px, settings.object_px
    hand_img, hand_mask = np.zeros((n, px, px), np.float32), np.zeros((n, px, px), bool)
    obj_img, obj_mask = np.zeros((n, so, so), np.float32), np.zeros((n, so, so), bool)
    hand = np.array([views.pose(pos[t], rots[t], qpos) for t in range(n)])
    # image motion during the exposure, in metres along the camera's image axes (x right, y down)
    blur_m = np.gradient(hand, axis=0) * settings.fps * settings.exposure_s @ cam_rot[:, :2]
    half_hand, half_obj = 0.16 * person.size, 1.2 * grip.radius_m
    window, box = None, None
    for t in range(n):  # one MuJoCo render per view and frame (the renderer is not batched)
        views.pose(pos[t], rots[t], qpos)
        grey, label = views.render(eye, hand[t], half_hand)
        blur = blur_m[t] * px / (2 * half_hand)
        mask = _motion_blur(skin_segment(label).astype(np.float32), blur) > 0.5
        mask = _jitter_mask(mask, rng)
        square = _square_box(mask)
        hand_img[t] = _crop_square(_motion_blur(grey, blur), square, px)
        hand_mask[t] = _crop_square(mask.astype(np.float32), square, px) > 0.5
        if window is None:  # the object window: placed relative to the hand, shaped in frame 0
            window = pos[0] + rots[0] @ grip.centre_m - hand[0]
        grey, label = views.render(eye, hand[t] + window, half_obj)
        if box is None:
            box = _bbox(label == 2)
        blur = blur_m[t] * px / (2 * half_obj)
        obj_img[t] = _crop_square(_motion_blur(grey, blur), box, so)
        obj_mask[t] = _crop_square(_motion_blur((label == 2).astype(np.float32), blur), box, so) > 0.5
    noise = settings.pixel_noise
    hand_img = np.clip(hand_img + noise * rng.standard_normal(hand_img.shape), 0, 1) * hand_mask
    obj_img = np.clip(obj_img + noise * rng.standard_normal(obj_img.shape), 0, 1) * obj_mask
    pos2d, pos3d = measured_positions(hand, person, rng, settings)
    return dict(n=n, hand_img=hand_img.astype(np.float32), hand_mask=hand_mask, obj_img=obj_img.astype(np.float32),
                obj_mask=obj_mask, pos2d=pos2d, pos3d=pos3d, hand_true=hand - face_point(person))


def masked_hog(images: np.ndarray, masks: np.ndarray, n_bins: int, n_levels: int) -> np.ndarray:
    """HOG (F, D) of segmented images (F, P, P) with masks; a frame with (almost) no pixels gets zeros."""
    from hog_jax import HOGConfig, hog, hog_dim

    config = HOGConfig(n_bins=n_bins, n_levels=n_levels)
    ok = (masks.sum(axis=(1, 2)) >= 4) & (images.reshape(len(images), -1).max(axis=1) > 0)
    out = np.zeros((len(images), hog_dim(config)), np.float32)
    if ok.any():
        out[ok] = np.asarray(hog(images[ok], config, mask=masks[ok]))
    return out
