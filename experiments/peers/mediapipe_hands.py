"""MediaPipe Hands, the modern peer of the hand finder, and the box scoring shared by every hand finder.

MediaPipe Hands (Zhang et al., "MediaPipe Hands: On-device Real-time Hand Tracking", CVPR workshops
2020) is a palm detector followed by a 21-landmark regressor; in video mode it detects palms only
until it has hands and then tracks them from the previous frame's landmarks. It runs here through the
legacy `mediapipe.solutions.hands` graph of `mediapipe` 0.10.21, whose wheel carries both models
(`mediapipe/modules/palm_detection`, `hand_landmark`); later wheels dropped them, and their Tasks API
downloads its model at run time. Its pins clash with ours, so it lives in its own environment:
`make peers` builds `.venv-peers`; run the benchmarks that use it with `.venv-peers/bin/python`.

    with MediaPipeHands(HandsOptions(static_image_mode=False)) as hands:
        found = [hands(frame) for frame in frames]          # RGB (H, W, 3) uint8 each
    found[0].boxes, found[0].handedness, found[0].scores

A hand's box is the bounding box of its 21 landmarks in pixels (x0, y0, x1, y1; continuous
coordinates, a pixel i spanning [i, i + 1)), clipped to the image: it is tight around the joints
(wrist to fingertips), not around the skin.

Scoring (`match_boxes`, `score_boxes`): boxes of one frame are matched greedily by intersection over
union, the best remaining pair first, a pair counting only at IoU >= `threshold`; a true box without
a match is a missed hand, a found box without a match a false box. The functions take any hand
finder's boxes, ours included. Boxes annotated as inclusive pixel indices convert with
`inclusive_to_edges`.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from typing import Any, NamedTuple

import numpy as np

__all__ = ["HandsOptions", "HandDetections", "MediaPipeHands", "box_iou", "detect_hands", "inclusive_to_edges",
           "match_boxes", "require_mediapipe", "score_boxes"]

MEDIAPIPE_VERSION = "0.10.21"  # the last wheel with `solutions.hands` and its .tflite models
N_LANDMARKS = 21


def require_mediapipe() -> Any:
    """The `mediapipe` module with its legacy Hands solution.

    Returns:
        The imported `mediapipe` module.

    Raises:
        ImportError: saying to run `make peers` (and use `.venv-peers/bin/python`) when `mediapipe` is
            not installed or has no `solutions.hands` (a wheel newer than 0.10.21).
    """
    hint = (f"MediaPipe Hands needs mediapipe=={MEDIAPIPE_VERSION} (the last wheel carrying the hand models), "
            "which clashes with this project's pins: run `make peers` and use `.venv-peers/bin/python`")
    try:
        import mediapipe as mp
    except ImportError as err:
        raise ImportError(f"mediapipe is not installed. {hint}") from err
    try:
        mp.solutions.hands  # noqa: B018 (the attribute access is the check)
    except AttributeError as err:
        raise ImportError(f"mediapipe {getattr(mp, '__version__', '?')} has no solutions.hands. {hint}") from err
    return mp


@dataclasses.dataclass(frozen=True)
class HandsOptions:
    """The options of `MediaPipeHands` (those of `mediapipe.solutions.hands.Hands`).

    Attributes:
        static_image_mode: True: every frame is a still, the palm detector runs on each (photos);
            False (default): video, the hands found are tracked from frame to frame and the detector
            runs only while fewer than `max_num_hands` are tracked.
        max_num_hands: at most this many hands per frame, >= 1 (default 2).
        model_complexity: 0 the lite landmark model, 1 (default) the full one.
        min_detection_confidence: in [0, 1], the palm detector's score threshold (default 0.5).
        min_tracking_confidence: in [0, 1], below this landmark score a tracked hand is dropped and
            detected again (default 0.5; video mode only).
    """

    static_image_mode: bool = False
    max_num_hands: int = 2
    model_complexity: int = 1
    min_detection_confidence: float = 0.5
    min_tracking_confidence: float = 0.5

    def __post_init__(self):
        if not isinstance(self.static_image_mode, (bool, np.bool_)):
            raise ValueError(f"static_image_mode: expected a bool, got {self.static_image_mode!r}")
        if isinstance(self.max_num_hands, bool) or not isinstance(self.max_num_hands, int) or self.max_num_hands < 1:
            raise ValueError(f"max_num_hands: expected an int >= 1, got {self.max_num_hands!r}")
        if self.model_complexity not in (0, 1):
            raise ValueError(f"model_complexity: expected 0 or 1, got {self.model_complexity!r}")
        for name in ("min_detection_confidence", "min_tracking_confidence"):
            value = getattr(self, name)
            if not 0.0 <= float(value) <= 1.0:
                raise ValueError(f"{name}: expected a value in [0, 1], got {value!r}")


class HandDetections(NamedTuple):
    """The hands MediaPipe found in one frame (N of them, N = 0 when none).

    Attributes:
        boxes: (N, 4) float, x0, y0, x1, y1 in pixels: the landmarks' bounding box, clipped to the image.
        landmarks: (N, 21, 2) float, the landmarks' x, y in pixels (not clipped).
        handedness: N labels "Left" / "Right" as MediaPipe gives them; it assumes a mirrored (selfie)
            image, so on an ordinary camera's frames "Left" is the person's right hand.
        scores: (N,) float, the handedness classifier's score of that label.
    """

    boxes: np.ndarray
    landmarks: np.ndarray
    handedness: tuple[str, ...]
    scores: np.ndarray


def _check_frame(frame: Any, name: str = "frame") -> np.ndarray:
    arr = np.asarray(frame)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"{name}: expected an RGB image (H, W, 3), got shape {arr.shape}")
    if arr.dtype != np.uint8:
        raise ValueError(f"{name}: expected dtype uint8, got {arr.dtype}")
    return np.ascontiguousarray(arr)


class MediaPipeHands:
    """MediaPipe Hands on RGB frames, one call per frame (a context manager: `close` frees the graph).

    Building it loads the models from the wheel (the model initialisation a benchmark times apart);
    in video mode (`HandsOptions.static_image_mode` False) the frames of one video go through one
    object in order, and a new video needs a new object.

    Args:
        options: the `HandsOptions`.

    Raises:
        ImportError: as `require_mediapipe`.
        ValueError: for options that are not `HandsOptions`.
    """

    def __init__(self, options: HandsOptions = HandsOptions()):
        if not isinstance(options, HandsOptions):
            raise ValueError(f"options: expected HandsOptions, got {type(options).__name__}")
        mp = require_mediapipe()
        self.options = options
        self._hands = mp.solutions.hands.Hands(**dataclasses.asdict(options))

    def __call__(self, frame: Any) -> HandDetections:
        """The hands of one frame.

        Args:
            frame: (H, W, 3) uint8 RGB.

        Returns:
            The `HandDetections` of the frame.

        Raises:
            ValueError: naming `frame` for another shape or dtype.
        """
        image = _check_frame(frame)
        height, width = image.shape[:2]
        result = self._hands.process(image)
        found = result.multi_hand_landmarks or []
        if not found:
            return HandDetections(np.zeros((0, 4)), np.zeros((0, N_LANDMARKS, 2)), (), np.zeros(0))
        landmarks = np.array([[(p.x * width, p.y * height) for p in hand.landmark] for hand in found], float)
        lo, hi = landmarks.min(axis=1), landmarks.max(axis=1)
        boxes = np.concatenate([lo, hi], axis=1)
        boxes = np.clip(boxes, 0.0, [width, height, width, height])
        classes = [h.classification[0] for h in (result.multi_handedness or [])]
        return HandDetections(boxes, landmarks, tuple(c.label for c in classes), np.array([c.score for c in classes]))

    def close(self) -> None:
        """Free the MediaPipe graph."""
        self._hands.close()

    def __enter__(self) -> MediaPipeHands:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def detect_hands(frames: Iterable[Any], options: HandsOptions = HandsOptions()) -> list[HandDetections]:
    """MediaPipe Hands over frames, in order, through one `MediaPipeHands`.

    Args:
        frames: RGB (H, W, 3) uint8 frames (an array (T, H, W, 3) or any iterable of frames); in video
            mode the frames of one video in order.
        options: the `HandsOptions`.

    Returns:
        One `HandDetections` per frame.

    Raises:
        ImportError: as `require_mediapipe`.
        ValueError: naming the argument for a frame of another shape or dtype, or bad options.
    """
    with MediaPipeHands(options) as hands:
        return [hands(frame) for frame in frames]


def inclusive_to_edges(boxes: Any) -> np.ndarray:
    """Boxes annotated as inclusive pixel indices (the last row and column inside) -> pixel edges.

    Args:
        boxes: (..., 4) xmin, ymin, xmax, ymax, inclusive.

    Returns:
        (..., 4) float x0, y0, x1, y1 = xmin, ymin, xmax + 1, ymax + 1.
    """
    out = np.array(boxes, float)
    if out.shape[-1:] != (4,):
        raise ValueError(f"boxes: expected shape (..., 4), got {out.shape}")
    out[..., 2:] += 1.0
    return out


def _check_boxes(boxes: Any, name: str) -> np.ndarray:
    arr = np.asarray(boxes, float).reshape(-1, 4) if np.size(boxes) == 0 else np.asarray(boxes, float)
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise ValueError(f"{name}: expected shape (N, 4), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite coordinates")
    if np.any(arr[:, 2] < arr[:, 0]) or np.any(arr[:, 3] < arr[:, 1]):
        raise ValueError(f"{name}: expected x1 >= x0 and y1 >= y0 in every box")
    return arr


def box_iou(a: Any, b: Any) -> np.ndarray:
    """Intersection over union of every pair of boxes.

    Args:
        a: (N, 4) boxes x0, y0, x1, y1 (continuous pixel coordinates).
        b: (M, 4) boxes.

    Returns:
        (N, M) IoU in [0, 1]; 0 for a pair whose union is empty.

    Raises:
        ValueError: naming the argument for another shape, non-finite values or x1 < x0 (y1 < y0).
    """
    a, b = _check_boxes(a, "a"), _check_boxes(b, "b")
    lo = np.maximum(a[:, None, :2], b[None, :, :2])
    hi = np.minimum(a[:, None, 2:], b[None, :, 2:])
    inter = np.prod(np.clip(hi - lo, 0.0, None), axis=-1)
    area = lambda x: (x[:, 2] - x[:, 0]) * (x[:, 3] - x[:, 1])
    union = area(a)[:, None] + area(b)[None, :] - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def match_boxes(found: Any, truth: Any, threshold: float = 0.5) -> list[tuple[int, int, float]]:
    """Greedy one-to-one matching of one frame's found boxes to its true boxes by IoU.

    The pair of highest IoU is matched first, both boxes leave, and so on while the best remaining
    pair reaches `threshold`.

    Args:
        found: (N, 4) the hand finder's boxes.
        truth: (M, 4) the true boxes.
        threshold: in (0, 1], the least IoU of a match.

    Returns:
        [(found index, true index, IoU)], best first.

    Raises:
        ValueError: naming the argument for bad boxes or a threshold outside (0, 1].
    """
    if not 0.0 < float(threshold) <= 1.0:
        raise ValueError(f"threshold: expected a value in (0, 1], got {threshold!r}")
    iou = box_iou(found, truth)
    pairs = []
    while iou.size and iou.max() >= threshold:
        i, j = np.unravel_index(int(np.argmax(iou)), iou.shape)
        pairs.append((int(i), int(j), float(iou[i, j])))
        iou[i, :], iou[:, j] = -1.0, -1.0
    return pairs


def score_boxes(found: Sequence[Any], truth: Sequence[Any], threshold: float = 0.5) -> dict[str, float]:
    """A hand finder's boxes against the true hand boxes over frames (`match_boxes` per frame).

    Args:
        found: per frame, (N_t, 4) the boxes found.
        truth: per frame, (M_t, 4) the true boxes (same number of frames).
        threshold: in (0, 1], the least IoU of a match.

    Returns:
        {"frames", "true_boxes", "found_boxes", "matched", "recall" (matched / true boxes, the share of
        hands found), "precision" (matched / found boxes; NaN when none was found),
        "false_boxes" (found boxes without a match), "false_boxes_per_frame", "mean_iou_matched" (NaN
        without a match), "mean_best_iou" (each true box's best IoU with any found box, matched or not,
        averaged over the true boxes; NaN without true boxes)}.

    Raises:
        ValueError: naming the argument for lists of different lengths, bad boxes or a bad threshold.
    """
    if len(found) != len(truth):
        raise ValueError(f"found: expected one entry per frame of truth ({len(truth)}), got {len(found)}")
    n_true = n_found = 0
    ious, best = [], []
    for t, (f, g) in enumerate(zip(found, truth)):
        f, g = _check_boxes(f, f"found[{t}]"), _check_boxes(g, f"truth[{t}]")
        n_true, n_found = n_true + len(g), n_found + len(f)
        ious += [m[2] for m in match_boxes(f, g, threshold)]
        if len(g):
            best += list(box_iou(f, g).max(axis=0)) if len(f) else [0.0] * len(g)
    matched = len(ious)
    nan = float("nan")
    return {"frames": len(truth), "true_boxes": n_true, "found_boxes": n_found, "matched": matched,
            "recall": matched / n_true if n_true else nan, "precision": matched / n_found if n_found else nan,
            "false_boxes": n_found - matched, "false_boxes_per_frame": (n_found - matched) / max(len(truth), 1),
            "mean_iou_matched": float(np.mean(ious)) if ious else nan,
            "mean_best_iou": float(np.mean(best)) if best else nan}
