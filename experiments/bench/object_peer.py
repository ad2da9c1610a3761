"""The modern peer of LfD 2009 §III-B's object segmentation (issue 19), as a practitioner would build
it today with OpenCV: dense disparity (`StereoSGBM`, semi-global matching) and dense optical flow
(`DISOpticalFlow`); the object is the pixels of the hand's window that move with the hand (flow
within `flow_tol` px of the hand's displacement) at the hand's depth (disparity within
`disparity_tol` px of the hand's). The same selection as ours follows (`hog_jax.object_masks`:
the hand's pixels removed, the nearest large region, holes filled, an opening), so that the two
differ only in the cues.

Frames are grey uint8 (T, H, W), positions (row, column). Frame 0 has no previous frame: not found.
"""
from __future__ import annotations

import cv2
import jax.numpy as jnp
import numpy as np

from hog_jax.phase_segmentation import LogRatio, object_masks

__all__ = ["peer_object_masks", "window"]


def window(image: np.ndarray, centre, half: tuple[int, int], fill=0):
    """The (2 hh + 1, 2 hw + 1) window of image (H, W, ...) around centre (row, column), `fill`
    outside the image."""
    hh, hw = half
    r, c = int(round(centre[0])), int(round(centre[1]))
    padded = np.pad(image, ((hh, hh), (hw, hw)) + ((0, 0),) * (image.ndim - 2), constant_values=fill)
    return padded[r:r + 2 * hh + 1, c:c + 2 * hw + 1]


def peer_object_masks(left: np.ndarray, right: np.ndarray, hand_left: np.ndarray, hand_right: np.ndarray,
                      hand_masks: np.ndarray, half_window: tuple[int, int], flow_tol: float = 1.5,
                      disparity_tol: float = 1.5, num_disparities: int = 64, block_size: int = 5,
                      min_fraction: float = 0.1, morphology: int = 2):
    """(masks (T, h, w), found (T,)) of the peer (module docstring) for grey stereo frames (T, H, W)."""
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=num_disparities, blockSize=block_size,
                                 P1=8 * block_size ** 2, P2=32 * block_size ** 2, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    T = left.shape[0]
    h, w = 2 * half_window[0] + 1, 2 * half_window[1] + 1
    score, valid, hands = np.full((T, h, w), -1.0, np.float32), np.zeros((T, h, w), bool), np.zeros((T, h, w), bool)
    for t in range(1, T):  # OpenCV's calls are per frame
        disparity = sgbm.compute(left[t], right[t]).astype(np.float32) / 16.0  # fixed point, 4 fractional bits
        back = dis.calc(left[t], left[t - 1], None)  # where each pixel of frame t was in frame t - 1 (dx, dy)
        moved = np.asarray(hand_left[t], float) - np.asarray(hand_left[t - 1], float)  # (rows, columns)
        hand_disparity = float(hand_left[t][1] - hand_right[t][1])
        d = window(disparity, hand_left[t], half_window, fill=-1.0)
        f = window(back, hand_left[t], half_window, fill=np.nan)
        with_hand = np.hypot(f[..., 0] + moved[1], f[..., 1] + moved[0]) < flow_tol
        at_depth = (d >= 0) & (np.abs(d - hand_disparity) < disparity_tol)
        score[t] = np.where(with_hand & at_depth, 1.0, -1.0)
        valid[t] = np.isfinite(f[..., 0]) & (d >= 0)
        hands[t] = window(hand_masks[t], hand_left[t], half_window, fill=False)
    zero = LogRatio(jnp.zeros((T, h, w)), jnp.ones((T, h, w), bool))
    masks, found = object_masks(LogRatio(jnp.asarray(score), jnp.asarray(valid)), zero, hands, threshold=0.0,
                                min_fraction=min_fraction, morphology=morphology)
    return np.asarray(masks), np.asarray(found) & (np.arange(T) > 0)
