"""Hands found in real RGB frames: skin blobs scored as hands, forearms cut off (GRASP §III-A's front end).

Shapes: B frames, H x W pixels (h x w at the working resolution), K = `max_hands` slots per frame.

GRASP §III-A takes the hand to be the largest skin blob. On real frames that finds skin-coloured
clutter (red packaging, jam, wood) as readily as hands, keeps the forearm in the hand's box and never
says "not found". `find_hands` keeps the colour model but asks more of a blob:

1. colour: the frames at the working resolution (longer side at most `max_side`, area-averaged in
   JAX), the skin model's log ratio per pixel (`skin_log_ratio`), vetoed by the `SkinRules` (luma,
   saturation, texture of skin-coloured non-skin);
2. the frame's own skin: the largest blob of confident skin (log ratio above threshold +
   `confident_margin`), eroded away from its outline, teaches the skin mixture this frame's skin
   colour (`adapt_to_skin`, Reynolds relevance MAP); the ratio is computed again under the adapted
   model (all frames at once, vmapped);
3. skin = ratio > threshold within the rules, 3 x 3 median three times (GRASP), 8-connected blobs
   (OpenCV);
4. the arm cut: a blob that touches an entry edge of the frame (in egocentric and over-the-table
   views arms enter from the bottom and the sides) is a forearm with the hand at its far end. The
   arm's direction runs from the blob's pixels on the edge to its farthest pixels; the arm's width is
   the blob's mean width across that direction over its half nearer the edge; the hand is the
   part within `hand_length` arm widths of the far end (the whole blob when it is shorter);
5. the score of a blob, in [0, 1]: the product of its colour confidence (the mean of
   sigmoid(ratio - threshold) over its pixels), its size (area over the frame, rising smoothly to 1
   at `full_area`), its solidity (area over convex hull area, rising to 1 at `full_solidity`) and,
   for a blob that touches no entry edge, `floating`; blobs below `min_area` or `min_score` are not
   hands. The best `max_hands` boxes are returned, best first; a frame without one says "not found".

Boxes are (top, left, bottom, right) in the input frames' pixels, bottom and right exclusive, as
`Segmentation.boxes`.
"""
from __future__ import annotations

import math
from functools import partial
from typing import NamedTuple

import cv2
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int, Real

from hog_jax._src.segment import SkinModel, log_ratio, median3
from hog_jax._src.skin_adapt import adapt_to_skin
from hog_jax._src.skin_rules import SkinRules, skin_rule_mask
from lfd_common import as_array, check_int, check_real

__all__ = ["HandBoxes", "HandOptions", "find_hands"]

EDGES = ("top", "bottom", "left", "right")


class HandOptions(NamedTuple):
    """Options of `find_hands` (GRASP §III-A's skin front end made to hold on real frames).

    The defaults were chosen on real frames (HGR persons id04-id05 and the first 16 gtea_grasps
    frames; `experiments.grasp_recognition.real_photos`) for `lfd_jax.fit_real_skin_model`'s model:
    there the adaptation, a luma floor, a box margin and a lower `floating` lost hands; pass the rules
    of `fit_skin_rules` (with min_luma 0) to veto saturated or textured skin-coloured pixels.

    Attributes:
        threshold: a pixel is skin where the skin model's log ratio exceeds this.
        rules: `SkinRules` vetoing skin-coloured non-skin pixels (None: no rules).
        adapt: whether each frame's confident skin teaches the skin mixture its colour.
        confident_margin: >= 0, the confident skin of the adaptation: log ratio > threshold + this.
        relevance: > 0, in pixels, the adaptation's relevance (`adapt_to_skin`).
        adapt_pixels: >= 16, the most confident pixels the adaptation uses (evenly strided).
        max_side: >= 32, the working resolution's longer side (frames larger are area-averaged down).
        max_hands: K >= 1, the most hands returned per frame.
        min_area: in [0, 1), a blob smaller than this fraction of the frame is not a hand.
        full_area: in (0, 1], the size factor of the score rises smoothly from 0 to 1 at this fraction.
        full_solidity: in (0, 1], the solidity factor rises linearly from 0 to 1 at this solidity.
        floating: in [0, 1], the score factor of a blob that touches no entry edge.
        entry_edges: the frame edges arms enter from, a subset of ("top", "bottom", "left", "right");
            empty: no arm cut and no entry factor.
        edge_band: in [0, 0.5], a blob with pixels this close to an entry edge (a fraction of the
            frame's shorter side; at least 1 pixel) enters from it.
        hand_length: > 0, the hand's length along the arm in arm widths (the cut).
        min_score: in [0, 1], a blob scoring below this is not a hand.

    Raises:
        ValueError: naming the field (`find_hands` validates them).
    """

    threshold: float = 1.5
    rules: SkinRules | None = None
    adapt: bool = False
    confident_margin: float = 2.0
    relevance: float = 16.0
    adapt_pixels: int = 4096
    max_side: int = 320
    max_hands: int = 2
    min_area: float = 0.004
    full_area: float = 0.06
    full_solidity: float = 0.4
    floating: float = 1.0
    entry_edges: tuple[str, ...] = ("bottom", "left", "right")
    edge_band: float = 0.03
    hand_length: float = 2.0
    min_score: float = 0.4


def check_options(options: HandOptions) -> HandOptions:
    """`options` when every field is valid; ValueError naming the field otherwise."""
    if not isinstance(options, HandOptions):
        raise ValueError(f"options: expected a HandOptions, got {type(options).__name__}")
    check_real(options.threshold, "threshold")
    if options.rules is not None and not isinstance(options.rules, SkinRules):
        raise ValueError(f"rules: expected a SkinRules or None, got {type(options.rules).__name__}")
    if not isinstance(options.adapt, (bool, np.bool_)):
        raise ValueError(f"adapt: expected a bool, got {options.adapt!r}")
    check_real(options.confident_margin, "confident_margin", min_value=0.0)
    check_real(options.relevance, "relevance", min_value=0.0, exclusive_min=True)
    check_int(options.adapt_pixels, "adapt_pixels", min_value=16)
    check_int(options.max_side, "max_side", min_value=32)
    check_int(options.max_hands, "max_hands", min_value=1)
    check_real(options.min_area, "min_area", min_value=0.0, max_value=1.0)
    if options.min_area >= 1.0:
        raise ValueError(f"min_area: expected a fraction in [0, 1), got {options.min_area}")
    check_real(options.full_area, "full_area", min_value=0.0, max_value=1.0, exclusive_min=True)
    check_real(options.full_solidity, "full_solidity", min_value=0.0, max_value=1.0, exclusive_min=True)
    check_real(options.floating, "floating", min_value=0.0, max_value=1.0)
    edges = options.entry_edges
    if isinstance(edges, str) or not isinstance(edges, tuple) or set(edges) - set(EDGES) or len(set(edges)) != len(edges):
        raise ValueError(f"entry_edges: expected a tuple of distinct names among {EDGES}, got {edges!r}")
    check_real(options.edge_band, "edge_band", min_value=0.0, max_value=0.5)
    check_real(options.hand_length, "hand_length", min_value=0.0, exclusive_min=True)
    check_real(options.min_score, "min_score", min_value=0.0, max_value=1.0)
    return options


class HandBoxes(NamedTuple):
    """The hands found in each frame, best first (GRASP §III-A).

    Attributes:
        boxes: (B, K, 4) int32 hand boxes (top, left, bottom, right) in the input frames' pixels,
            bottom and right exclusive; -1 in a slot without a hand.
        arm_boxes: (B, K, 4) int32 boxes of the whole blob each hand was cut from (the hand with its
            forearm); -1 in a slot without a hand.
        scores: (B, K) float32 hand scores in [0, 1], best first; 0 in a slot without a hand.
        found: (B, K) bool, the slot holds a hand; `found[:, 0]` False: "not found" in that frame.
    """

    boxes: Int[Array, "B K 4"]
    arm_boxes: Int[Array, "B K 4"]
    scores: Float[Array, "B K"]
    found: Bool[Array, "B K"]


def _work_size(H: int, W: int, max_side: int) -> tuple[int, int]:
    scale = min(1.0, max_side / max(H, W))
    return max(1, round(H * scale)), max(1, round(W * scale))


@partial(jax.jit, static_argnames=("size",))
def _resize(frames, size: tuple[int, int]):
    if frames.shape[1:3] == size:
        return frames
    # rounding lifts a saturated pixel a hair above 255, which the skin rules' range check refuses
    return jnp.clip(jax.image.resize(frames, (frames.shape[0], *size, 3), "linear", antialias=True), 0.0, 255.0)


@jax.jit
def _ratios(models: SkinModel, frames):
    """(B, h, w) log ratios of each frame under its own model (every array of `models` with a B axis)."""
    return jax.vmap(log_ratio)(models, frames)


@jax.jit
def _skin(ratio, allowed, threshold):
    return median3((ratio > threshold) & allowed, 3)


def _largest(mask: np.ndarray) -> np.ndarray:
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return np.zeros(mask.shape, bool)
    return labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))


def _adapted(model: SkinModel, frames: np.ndarray, ratio: np.ndarray, allowed: np.ndarray,
             o: HandOptions) -> np.ndarray:
    """(B, h, w) log ratios under each frame's model adapted to its confident skin (step 2); a frame
    whose confident blob has fewer than 16 pixels keeps the global model."""
    confident = np.asarray(median3(jnp.asarray((ratio > o.threshold + o.confident_margin) & allowed), 3))
    models = []
    for frame, c in zip(frames, confident):
        blob = cv2.erode(_largest(c).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
        pixels = frame[blob]
        pixels = pixels[::max(1, math.ceil(len(pixels) / o.adapt_pixels))]
        models.append(adapt_to_skin(model, pixels, relevance=o.relevance) if len(pixels) >= 16 else model)
    stacked = jax.tree.map(lambda *a: jnp.stack(a), *models)
    return np.asarray(_ratios(stacked, jnp.asarray(frames)))


class Blob(NamedTuple):
    """One skin blob of a frame at the working resolution: its hand box and whole box (top, left,
    bottom, right) and what its score is made of: colour confidence, area over the frame, solidity,
    whether it enters from an entry edge."""

    box: tuple[int, int, int, int]
    arm_box: tuple[int, int, int, int]
    colour: float
    area: float
    solidity: float
    entry: bool


def _box(rows: np.ndarray, cols: np.ndarray) -> tuple[int, int, int, int]:
    return int(rows.min()), int(cols.min()), int(rows.max()) + 1, int(cols.max()) + 1


def _hand_part(rows: np.ndarray, cols: np.ndarray, entering: np.ndarray, hand_length: float) -> np.ndarray:
    """The pixels of an arm blob that are its hand (step 4): within hand_length arm widths of the
    end farthest from the entry (the mean of its pixels near the entry edges, `entering`)."""
    p = np.stack([rows, cols], 1).astype(np.float64)
    entry = p[entering].mean(0)
    d = np.linalg.norm(p - entry, axis=1)
    far = p[d >= np.quantile(d, 0.95)].mean(0)
    if np.linalg.norm(far - entry) < 1.0:
        return np.ones(len(p), bool)
    u = (far - entry) / np.linalg.norm(far - entry)
    t = (p - entry) @ u
    length = np.quantile(t, 0.995)
    # the mean width over the near half: pixels per unit length (per-step bins alias on a pixel grid)
    width = np.count_nonzero((t >= 0) & (t < length / 2)) / max(length / 2, 1.0)
    return t >= length - hand_length * width


def _blobs(mask: np.ndarray, ratio: np.ndarray, o: HandOptions) -> list[Blob]:
    """Steps 4-5 on one frame's skin mask (h, w) and log ratio (h, w): its blobs of at least min_area."""
    h, w = mask.shape
    band = max(1, round(o.edge_band * min(h, w)))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    out = []
    for k in np.flatnonzero(stats[1:, cv2.CC_STAT_AREA] >= o.min_area * h * w) + 1:
        rows, cols = np.nonzero(labels == k)
        near = {"top": rows < band, "bottom": rows >= h - band, "left": cols < band, "right": cols >= w - band}
        entering = np.zeros(len(rows), bool)
        for e in o.entry_edges:
            entering |= near[e]
        entry = bool(entering.sum() >= 2)
        hand = _hand_part(rows, cols, entering, o.hand_length) if entry else np.ones(len(rows), bool)
        hull = cv2.contourArea(cv2.convexHull(np.stack([cols, rows], 1).astype(np.int32)))
        colour = float(np.mean(0.5 + 0.5 * np.tanh(0.5 * (ratio[rows, cols] - o.threshold))))  # sigmoid
        out.append(Blob(_box(rows[hand], cols[hand]), _box(rows, cols), colour, len(rows) / (h * w),
                        min(1.0, len(rows) / max(hull, 1.0)), entry))
    return out


def blob_score(blob: Blob, o: HandOptions) -> float:
    """A blob's hand score in [0, 1] (step 5): colour x size x solidity x entry."""
    size = min(1.0, blob.area / o.full_area) ** 0.5
    solidity = min(1.0, blob.solidity / o.full_solidity)
    entry = 1.0 if blob.entry or not o.entry_edges else o.floating
    return blob.colour * size * solidity * entry


def _inside(a, b) -> float:
    """The share of box a's area inside box b."""
    h = max(0, min(a[2], b[2]) - max(a[0], b[0]))
    w = max(0, min(a[3], b[3]) - max(a[1], b[1]))
    return h * w / max((a[2] - a[0]) * (a[3] - a[1]), 1)


def choose(blobs: list[Blob], o: HandOptions) -> list[tuple[Blob, float]]:
    """The hands of one frame, best first: blobs scoring at least min_score, a blob whose hand box
    lies mostly (over half) inside the whole box of a better one left out (a piece of the same arm,
    split by a shadow or a held object), at most max_hands."""
    kept = []
    for blob, score in sorted(((b, blob_score(b, o)) for b in blobs), key=lambda x: -x[1]):
        if score >= o.min_score and all(_inside(blob.box, k.arm_box) <= 0.5 for k, _ in kept):
            kept.append((blob, score))
    return kept[:o.max_hands]


def _check_frames(frames) -> np.ndarray:
    arr = as_array(frames, "frames", ndim=4, dtype=np.float32, min_value=0, max_value=255)
    if arr.shape[-1] != 3:
        raise ValueError(f"frames: expected (B, H, W, 3) RGB frames, got shape {arr.shape}")
    return arr


def frame_blobs(model: SkinModel, frames: Real[ArrayLike, "B H W 3"], options: HandOptions = HandOptions()
                ) -> tuple[list[list[Blob]], tuple[int, int]]:
    """Every scored blob of every frame at the working resolution (steps 1-5 before the choice), and
    the working size (h, w); `find_hands` keeps the best."""
    o = check_options(options)
    if not isinstance(model, SkinModel):
        raise ValueError(f"model: expected a hog_jax.SkinModel, got {type(model).__name__}")
    arr = _check_frames(frames)
    size = _work_size(arr.shape[1], arr.shape[2], o.max_side)
    work = np.asarray(_resize(jnp.asarray(arr), size))
    ratio = np.asarray(log_ratio(model, jnp.asarray(work)))
    allowed = (np.asarray(skin_rule_mask(o.rules, work)) if o.rules is not None else np.ones(ratio.shape, bool))
    if o.adapt:
        ratio = _adapted(model, work, ratio, allowed, o)
    skin = np.asarray(_skin(jnp.asarray(ratio), jnp.asarray(allowed), jnp.float32(o.threshold)))
    return [_blobs(m, r, o) for m, r in zip(skin, ratio)], size


def find_hands(model: SkinModel, frames: Real[ArrayLike, "B H W 3"],
               options: HandOptions = HandOptions()) -> HandBoxes:
    """The hands in RGB frames: skin blobs scored as hands, forearms cut off (GRASP §III-A).

    Per frame: the skin model's log ratio at the working resolution with the `SkinRules` vetoes; the
    skin mixture adapted to the frame's confident skin (`adapt_to_skin`) and the ratio again; skin
    blobs (3 x 3 median x 3, 8-connectivity); a blob entering from an entry edge cut to its far end's
    `hand_length` arm widths (the hand without its forearm); each blob scored by colour confidence x
    size x solidity x entry; the best `max_hands` blobs scoring at least `min_score` are the hands.

    Args:
        model: the `SkinModel` (e.g. `lfd_jax.fit_real_skin_model`), chroma or chroma + luma.
        frames: (B, H, W, 3) RGB frames, uint8 or real in [0, 255].
        options: the `HandOptions`.

    Returns:
        `HandBoxes` with K = options.max_hands slots per frame, best first; a frame where no blob is
        a hand has found[b, 0] False and boxes -1 ("not found", never a default box).

    Raises:
        ValueError: naming the argument for frames that are not (B, H, W, 3) in [0, 255] or a model
            that is not a `SkinModel`, and naming the field for invalid options.
    """
    blobs, (h, w) = frame_blobs(model, frames, options)
    H, W = np.shape(frames)[1:3]
    K = options.max_hands
    boxes = np.full((len(blobs), K, 4), -1, np.int32)
    arm_boxes = np.full((len(blobs), K, 4), -1, np.int32)
    scores = np.zeros((len(blobs), K), np.float32)
    found = np.zeros((len(blobs), K), bool)
    scale = np.array([H / h, W / w, H / h, W / w])
    limit = np.array([H, W, H, W])
    for b, frame in enumerate(blobs):
        for k, (blob, score) in enumerate(choose(frame, options)):
            boxes[b, k] = np.clip(np.round(np.array(blob.box) * scale), 0, limit)
            arm_boxes[b, k] = np.clip(np.round(np.array(blob.arm_box) * scale), 0, limit)
            scores[b, k], found[b, k] = score, True
    return HandBoxes(jnp.asarray(boxes), jnp.asarray(arm_boxes), jnp.asarray(scores), jnp.asarray(found))
