"""The modern peer of LfD 2009 §III-B's object segmentation, as a practitioner would build
it today with OpenCV: dense disparity (`StereoSGBM`, semi-global matching) and dense optical flow
(`DISOpticalFlow`); the object is the pixels of the hand's window that move with the hand (flow
within `flow_tol` px of the hand's displacement) at the hand's depth (disparity within
`disparity_tol` px of the hand's). The same selection as ours follows (`hog_jax.video.object_masks`:
the hand's pixels removed, the nearest large region, holes filled, an opening), so that the two
differ only in the cues.

Both fields are computed on the full frames (`crop_margin=None`) or, the fast path for windows, on
crops around each frame's window (`crop_margin` px): SGBM on the same rows and columns of both
views, the window grown by the block's half width on every side and by `num_disparities` more on
the left (every window pixel keeps its whole disparity search and its block; OpenCV leaves the
first `num_disparities` columns of its input without a disparity); DIS on frames t and t - 1
cropped to the window grown by `crop_margin` on every side (room for the motion, the patches and
the pyramid). Crops are clipped to the image, then grown towards its inside where OpenCV needs
more (SGBM more columns than disparities, DIS `_DIS_MIN` px each way). SGBM's path costs and DIS's
pyramid and variational refinement see only the crop, so the fields inside the window are close
to, not equal to, the full frames' (the bench reports the IoU of both).

Frames are grey uint8 (T, H, W), positions (row, column). Frame 0 has no previous frame: not found.
"""
from __future__ import annotations

import cv2
import jax.numpy as jnp
import numpy as np

from hog_jax.video import LogRatio, object_masks

__all__ = ["peer_object_masks", "window"]

_DIS_MIN = 32  # px: OpenCV 5.1's DIS raises on images under 12 px each way, crashes on short wide ones (13 x 40)


def window(image: np.ndarray, centre, half: tuple[int, int], fill=0):
    """The (2 hh + 1, 2 hw + 1) window of image (H, W, ...) around centre (row, column), `fill`
    outside the image."""
    hh, hw = half
    r, c = int(round(centre[0])), int(round(centre[1]))
    padded = np.pad(image, ((hh, hh), (hw, hw)) + ((0, 0),) * (image.ndim - 2), constant_values=fill)
    return padded[r:r + 2 * hh + 1, c:c + 2 * hw + 1]


def _crop(shape: tuple[int, int], centre: tuple[int, int], half: tuple[int, int], margin: int | None,
          left: int = 0, min_size: tuple[int, int] = (1, 1)) -> tuple[slice, slice]:
    """(rows, columns) of an image of `shape` (H, W): the window of `half` around the integer centre
    grown by `margin` px on every side and `left` px more on the left, clipped to the image and grown
    towards its inside to at least `min_size` where the image allows; the whole image when margin
    is None."""
    if margin is None:
        return slice(0, shape[0]), slice(0, shape[1])
    (r, c), (hh, hw) = centre, half
    return (_span(r - hh - margin, r + hh + margin + 1, shape[0], min_size[0]),
            _span(c - hw - margin - left, c + hw + margin + 1, shape[1], min_size[1]))


def _span(start: int, stop: int, n: int, size: int) -> slice:
    """[start, stop) clipped to [0, n), then grown to `size` (forwards first) where n allows."""
    start, stop = max(start, 0), min(stop, n)
    stop = min(max(stop, start + size), n)
    return slice(max(min(start, stop - size), 0), stop)


def _in_crop(field: np.ndarray, centre: tuple[int, int], box: tuple[slice, slice], half, fill):
    """The window around centre (image coordinates) of a field computed on the crop `box`."""
    return window(field, (centre[0] - box[0].start, centre[1] - box[1].start), half, fill=fill)


def peer_object_masks(left: np.ndarray, right: np.ndarray, hand_left: np.ndarray, hand_right: np.ndarray,
                      hand_masks: np.ndarray, half_window: tuple[int, int], flow_tol: float = 1.5,
                      disparity_tol: float = 1.5, num_disparities: int = 64, block_size: int = 5,
                      min_fraction: float = 0.1, morphology: int = 2, crop_margin: int | None = None):
    """(masks (T, h, w), found (T,)) of the peer (module docstring) for grey stereo frames (T, H, W),
    on the full frames (`crop_margin=None`) or on crops around the windows."""
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=num_disparities, blockSize=block_size,
                                 P1=8 * block_size ** 2, P2=32 * block_size ** 2, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    T, shape = left.shape[0], left.shape[1:]
    h, w = 2 * half_window[0] + 1, 2 * half_window[1] + 1
    block_margin = None if crop_margin is None else block_size // 2
    score, valid, hands = np.full((T, h, w), -1.0, np.float32), np.zeros((T, h, w), bool), np.zeros((T, h, w), bool)
    for t in range(1, T):  # OpenCV's calls are per frame
        centre = (int(round(hand_left[t][0])), int(round(hand_left[t][1])))
        stereo = _crop(shape, centre, half_window, block_margin, left=num_disparities,
                       min_size=(1, num_disparities + 1))
        flow = _crop(shape, centre, half_window, crop_margin, min_size=(_DIS_MIN, _DIS_MIN))
        disparity = sgbm.compute(np.ascontiguousarray(left[t][stereo]), np.ascontiguousarray(right[t][stereo]))
        # where each pixel of frame t was in frame t - 1 (dx, dy)
        back = dis.calc(np.ascontiguousarray(left[t][flow]), np.ascontiguousarray(left[t - 1][flow]), None)
        moved = np.asarray(hand_left[t], float) - np.asarray(hand_left[t - 1], float)  # (rows, columns)
        hand_disparity = float(hand_left[t][1] - hand_right[t][1])
        # SGBM's fixed point has 4 fractional bits
        d = _in_crop(disparity.astype(np.float32) / 16.0, centre, stereo, half_window, -1.0)
        f = _in_crop(back, centre, flow, half_window, np.nan)
        with_hand = np.hypot(f[..., 0] + moved[1], f[..., 1] + moved[0]) < flow_tol
        at_depth = (d >= 0) & (np.abs(d - hand_disparity) < disparity_tol)
        score[t] = np.where(with_hand & at_depth, 1.0, -1.0)
        valid[t] = np.isfinite(f[..., 0]) & (d >= 0)
        hands[t] = window(hand_masks[t], hand_left[t], half_window, fill=False)
    zero = LogRatio(jnp.zeros((T, h, w)), jnp.ones((T, h, w), bool))
    masks, found = object_masks(LogRatio(jnp.asarray(score), jnp.asarray(valid)), zero, hands, threshold=0.0,
                                min_fraction=min_fraction, morphology=morphology)
    return np.asarray(masks), np.asarray(found) & (np.arange(T) > 0)
