"""Where a transfer put its object, read from the scene instead of the hand (LFD §III, MAP §VI).

The hand's displacement between the grasp moment and the put-down is what the tracker is worst at (the
hand holds the object there: 16.4 cm median error on the simulated validation transfers, against 1.7 cm
for the true hand). The object itself stands still before the movement and after it, in many frames.
The left view at rest before the movement (B) and after it (A) differ where the object left and where
it arrived, and where the person's posture differs. The object that moved is the one whose old
position changed (`moved_object`; the PHMMs' target where that does not decide). Its old view is B's
changed pixels inside the image box of an object standing at its old position (the paper assumes the
objects' poses are known before the demonstration; MAP §VI), and its new place the displacement of that
view that best matches A among those that land on changed pixels (the mean RGB distance, each pixel's
truncated so that a hand or another object in front of part of it costs a bounded amount). The place is
the old position plus that displacement on a horizontal plane, at the height where the old view's
centroid ray passes over the old position. The displacement is looked for, not paired with a second
changed region, so an object moved by less than its width (old and new silhouettes one region) or put
down partly behind another is found; where no displacement matches, nothing is found and the caller
falls back to the hand.

The old view is scaled by the ratio of the object's depths at its old and new places (an object moved
away from the camera looks smaller). A uniformly coloured object moved by less than its width matches
equally well at any displacement that keeps its old view's changed part inside its new silhouette: its
place is then off by up to the overlap (texture and shading decide it on real and rendered objects).

Chosen on the quick preset's simulated validation transfers (seeds 1001-1003, the rest frames around
the recognised movement): within 5 cm of the place in 16 of 17 (pairing the old silhouette with the
most similar second changed region, the rule before: 8, most failures an object moved by less than its
width or put down partly behind another); on seeds 1004-1006 (never used to choose) 15 of 18 (before:
11), the places not found taken from the hand.
"""
from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from lfd_common import check_int, check_real


class ScenePlace(NamedTuple):
    """What the scene shows of a transfer (module docstring).

    Attributes:
        moved: the object that the scene shows moved (-1: not decided, `moved_object`).
        xy: (2,) world m, where the object (`moved`, else the caller's target) now stands (NaN if not
            found).
        found: whether `xy` was found.
        reason: why not ("" when found).
        still: no object's old position changed (`changed_shares` all below `scene_place`'s
            still_share: nothing was moved).
    """

    moved: int
    xy: np.ndarray
    found: bool
    reason: str
    still: bool = False


def _not_found(moved: int, reason: str, still: bool = False) -> ScenePlace:
    return ScenePlace(moved, np.full(2, np.nan), False, reason, still)


def pixel_ray(P: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rays through pixels of a pinhole camera, world coordinates.

    Args:
        P: (3, 4) camera matrix.
        uv: (..., 2) pixels (column, row).

    Returns:
        (camera centre (3,), directions (..., 3)).
    """
    M, p4 = P[:, :3], P[:, 3]
    uv = np.asarray(uv, float)
    homogeneous = np.concatenate([uv, np.ones((*uv.shape[:-1], 1))], axis=-1)
    return -np.linalg.solve(M, p4), np.linalg.solve(M, homogeneous.reshape(-1, 3).T).T.reshape(homogeneous.shape)


def project(P: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The pixel of a world point through a pinhole camera.

    Args:
        P: (3, 4) camera matrix.
        X: (3,) world point.

    Returns:
        (2,) the pixel (column, row).
    """
    x = P @ np.r_[X, 1.0]
    return x[:2] / x[2]


def _on_plane(P, uv, height: float) -> np.ndarray:
    """(..., 2) pixels (column, row) -> (..., 2) where their rays cross the plane z = height (world x, y)."""
    centre, direction = pixel_ray(P, uv)
    return centre[:2] + ((height - centre[2]) / direction[..., 2])[..., None] * direction[..., :2]


def _height_over(P, uv, xy) -> float:
    """The height at which the ray through uv passes nearest (in x, y) over the table point xy (2,)."""
    centre, direction = pixel_ray(P, uv)
    d = direction[:2]
    lam = float(d @ (np.asarray(xy) - centre[:2]) / (d @ d))
    return float(centre[2] + lam * direction[2])


def _changed(before: np.ndarray, after: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(B, A) the median views (H, W, 3) float, B's overall brightness matched to A's (the scene's
    lights vary), and where they differ by more than `threshold` (summed over channels)."""
    b, a = (np.median(x.astype(np.float32), axis=0) for x in (before, after))
    gain = np.median(a.sum(-1) + 1.0) / np.median(b.sum(-1) + 1.0)
    return gain * b, a, np.abs(a - gain * b).sum(-1) > threshold


def changed_shares(changed: np.ndarray, old_px: np.ndarray, radius_px: float) -> np.ndarray:
    """The changed share of the pixels around each object's old position in the image.

    Args:
        changed: (H, W) bool, where the scene changed.
        old_px: (K, 2) the objects' old positions (column, row).
        radius_px: the disc's radius (pixels).

    Returns:
        (K,) the share of changed pixels within `radius_px` of each; 0 where it lies outside the image.
    """
    rows, cols = np.indices(changed.shape)
    return np.array([changed[(cols - u) ** 2 + (rows - v) ** 2 <= radius_px ** 2].mean()
                     if (0 <= u < changed.shape[1] and 0 <= v < changed.shape[0]) else 0.0 for u, v in old_px])


def moved_object(changed: np.ndarray, old_px: np.ndarray, radius_px: float, min_share: float = 0.25,
                 max_second: float = 0.5) -> int:
    """The object whose old position changed (`changed_shares`).

    Chosen on 24 simulated validation transfers (true rest frames): decided in 22, right in 21 (the
    wrong one: a pitcher put down in front of the binoculars); with min_share 0.5, decided in 12, all
    right.

    Args:
        changed: (H, W) bool, where the scene changed.
        old_px: (K, 2) the objects' old positions (column, row).
        radius_px: `changed_shares`' disc radius (pixels).
        min_share: the least share of the moved object.
        max_second: the second largest share must be less than this times the largest.

    Returns:
        The object with the largest share, where it is at least `min_share` and the second largest less
        than `max_second` times it, else -1 (not decided: e.g. the object arrived right beside another).
    """
    return _decided(changed_shares(changed, old_px, radius_px), min_share, max_second)


def _decided(shares: np.ndarray, min_share: float = 0.25, max_second: float = 0.5) -> int:
    """`moved_object`'s rule on the objects' changed shares (K,)."""
    if len(shares) == 0:
        return -1
    order = np.argsort(shares)[::-1]
    second = shares[order[1]] if len(shares) > 1 else 0.0
    return int(order[0]) if shares[order[0]] >= min_share and second < max_second * shares[order[0]] else -1


def _object_box(P: np.ndarray, xy: np.ndarray, table_z: float, half_m: float, height_m: float,
                shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """(row0, row1, col0, col1): the image box, clipped to the image, of an upright box of half footprint
    `half_m` and height `height_m` standing on the table at xy."""
    corners = np.array([project(P, np.r_[xy[0] + sx * half_m, xy[1] + sy * half_m, table_z + sz * height_m])
                        for sx in (-1, 1) for sy in (-1, 1) for sz in (0, 1)])
    c0, r0 = np.floor(corners.min(axis=0)).astype(int)
    c1, r1 = np.ceil(corners.max(axis=0)).astype(int) + 1
    return max(r0, 0), min(r1, shape[0]), max(c0, 0), min(c1, shape[1])


def _search_radius(P: np.ndarray, xy: np.ndarray, table_z: float, search_m: float) -> int:
    """The largest image distance (pixels) of a move by `search_m` along the table's x or y from xy."""
    here = project(P, np.r_[xy, table_z])
    return int(np.ceil(max(np.linalg.norm(project(P, np.r_[xy + step, table_z]) - here)
                           for step in ([search_m, 0.0], [0.0, search_m]))))


_CANDIDATES_PER_STEP = 256  # displacements compared at once: (256, pixels, 3) floats, a few MB


def _match_displacement(view: np.ndarray, after: np.ndarray, changed: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                        radius: int, scale_of, admissible, min_changed: float = 0.3,
                        cap: float = 60.0) -> tuple[np.ndarray, float]:
    """The displacement of an object's old view that best matches the view after it moved.

    Every displacement d != 0 within `radius` pixels (each axis) that puts at least `min_changed` of the
    object's pixels on changed pixels (an object arrives where the scene changed) is scored by the mean RGB
    distance between the object's old pixels and the after view's pixels at their displaced places, the
    view scaled about its centroid by `scale_of(d)` (an object moved away from the camera looks smaller),
    each distance truncated at `cap` (a pixel hidden by the hand or by another object costs `cap`, not more).

    Args:
        view: (H, W, 3) the view before the move (float).
        after: (H, W, 3) the view after it.
        changed: (H, W) bool, where the two differ.
        rows: (n,) the object's pixels in `view`, rows.
        cols: (n,) and columns.
        radius: the largest displacement along each axis (pixels).
        scale_of: (m, 2) displacements (columns, rows) -> (m,) the object's image scale there over its old one.
        admissible: (m, 2) displacements -> (m,) bool, where the object may stand after them (on the table).
        min_changed: the least share of the displaced pixels that changed.
        cap: the truncation of a pixel's RGB distance.

    Returns:
        (d (2,) (columns, rows) of the best displacement, its cost); cost inf where no displacement qualifies.
    """
    n = len(rows)
    r0, c0 = rows.min(), cols.min()
    shape = np.zeros((rows.max() - r0 + 1, cols.max() - c0 + 1), np.float32)
    shape[rows - r0, cols - c0] = 1.0
    padded = np.pad(changed.astype(np.float32), radius)
    around = padded[r0:r0 + shape.shape[0] + 2 * radius, c0:c0 + shape.shape[1] + 2 * radius]
    share = cv2.matchTemplate(around, shape, cv2.TM_CCORR) / n  # (2 radius + 1)^2, index (dy + radius, dx + radius)
    share[radius, radius] = 0.0  # d = 0: the object's old pixels all changed because it left; not a place
    dy, dx = np.nonzero(share >= min_changed - 1e-4)
    dy, dx = dy - radius, dx - radius
    keep = admissible(np.stack([dx, dy], axis=1).astype(float)) if len(dy) else np.zeros(0, bool)
    dy, dx = dy[keep], dx[keep]
    if not len(dy):
        return np.zeros(2), np.inf
    scale = scale_of(np.stack([dx, dy], axis=1).astype(float))
    old = view[rows, cols]
    centre_r, centre_c = rows.mean(), cols.mean()
    H, W = changed.shape

    def costs(k: np.ndarray) -> np.ndarray:
        r = np.rint(centre_r + dy[k, None] + scale[k, None] * (rows[None] - centre_r)).astype(int)  # (m, n)
        c = np.rint(centre_c + dx[k, None] + scale[k, None] * (cols[None] - centre_c)).astype(int)
        inside = (r >= 0) & (r < H) & (c >= 0) & (c < W)
        seen = after[np.clip(r, 0, H - 1), np.clip(c, 0, W - 1)]  # (m, n, 3)
        distance = np.minimum(np.linalg.norm(seen - old[None], axis=-1), cap)
        return np.where(inside, distance, cap).mean(axis=1)

    # in steps of candidates, so that the gathered pixels stay small whatever the radius
    cost = np.concatenate([costs(k) for k in np.array_split(np.arange(len(dy)), -(-len(dy) // _CANDIDATES_PER_STEP))])
    best = int(np.argmin(cost))
    return np.array([dx[best], dy[best]], float), float(cost[best])


def scene_place(before: np.ndarray, after: np.ndarray, P: np.ndarray, objects_xy: np.ndarray, target: int,
                table_z: float, look_height: float = 0.05, threshold: float = 40.0, radius_px: float = 5.0,
                still_share: float = 0.15, min_px: int = 20, object_half_m: float = 0.08,
                object_height_m: float = 0.25, search_m: float = 0.6, min_changed: float = 0.3, cap: float = 60.0,
                max_cost: float = 40.0, table_xy: tuple[tuple[float, float], tuple[float, float]] | None = None
                ) -> ScenePlace:
    """Which object was moved and where it now stands, from the scene at rest before and after a
    movement (module docstring; MAP §VI: the objects' poses are known before the demonstration).

    Where the scene does not decide which object moved (`moved_object`), the object `target` (the
    caller's guess, e.g. the PHMM's) is looked for. Its old view is the changed pixels of the view before
    inside the image box of the largest object (`object_half_m`, `object_height_m`) standing at its old
    position; the displacement of that view that best matches the view after (`_match_displacement`) moves
    its centroid, and the place is the old position plus that move on the horizontal plane where the
    centroid's ray passes over the old position. Not found (a flagged result, never a guess) where the old
    view did not change or no displacement matches.

    Args:
        before: (n, H, W, 3) uint8 frames of one view with the scene at rest before the movement.
        after: (n, H, W, 3) the same view at rest after it.
        P: (3, 4) that view's camera matrix.
        objects_xy: (K, 2) where the objects stood, world m.
        target: the caller's guess of the moved object (an index of `objects_xy`).
        table_z: the table top's height (world m).
        look_height: above the table top (m), where an object's old position is looked up.
        threshold: the change of a pixel (0-765, channels summed) that counts.
        radius_px: `moved_object`'s disc radius (pixels).
        still_share: below it at every object, nothing was moved (on 24 simulated validation transfers
            and 12 pointings: the moved object's share 0.35 or more, every share of a pointing 0.06 or
            less).
        min_px: the fewest changed pixels of the old view.
        object_half_m: half the footprint of the largest object (m).
        object_height_m: the largest object's height (m).
        search_m: the longest move looked for, along the table's x or y (m).
        min_changed: the match's least changed share at the new place.
        cap: the match's truncation of a pixel's RGB distance.
        max_cost: the largest mean truncated RGB distance of a match.
        table_xy: ((x low, x high), (y low, y high)) the table top, world m: a displacement that would
            put the object off it is not a place (a white cup matched on a white shirt behind it); None:
            anywhere.

    Returns:
        The `ScenePlace`.

    Raises:
        ValueError: bad frames, camera matrix, positions, target or a parameter out of its range (the message
            names the argument).
    """
    for name, frames in (("before", before), ("after", after)):
        if frames.ndim != 4 or frames.shape[-1] != 3 or len(frames) == 0:
            raise ValueError(f"{name}: expected (n >= 1, H, W, 3) frames, got {frames.shape}")
    if before.shape[1:] != after.shape[1:]:
        raise ValueError(f"after: frame size {after.shape[1:]} differs from before's {before.shape[1:]}")
    P, objects_xy = np.asarray(P, np.float64), np.asarray(objects_xy, np.float64)
    if P.shape != (3, 4) or not np.isfinite(P).all():
        raise ValueError(f"P: expected a finite (3, 4) camera matrix, got {P.shape}")
    if objects_xy.ndim != 2 or objects_xy.shape[1] != 2 or not len(objects_xy) or not np.isfinite(objects_xy).all():
        raise ValueError(f"objects_xy: expected finite (K >= 1, 2) positions, got {objects_xy.shape}")
    if not 0 <= target < len(objects_xy):
        raise ValueError(f"target: expected an index of objects_xy (0-{len(objects_xy) - 1}), got {target}")
    check_real(table_z, "table_z")
    check_real(look_height, "look_height")
    for name, value in (("threshold", threshold), ("radius_px", radius_px), ("object_half_m", object_half_m),
                        ("object_height_m", object_height_m), ("search_m", search_m), ("cap", cap)):
        check_real(value, name, min_value=0.0, exclusive_min=True)
    for name, value in (("still_share", still_share), ("min_changed", min_changed)):
        check_real(value, name, min_value=0.0, max_value=1.0)
    check_real(max_cost, "max_cost", min_value=0.0)
    check_int(min_px, "min_px", min_value=1)
    if table_xy is not None:
        bounds = np.asarray(table_xy, np.float64)
        if bounds.shape != (2, 2) or not np.isfinite(bounds).all() or (bounds[:, 0] >= bounds[:, 1]).any():
            raise ValueError(f"table_xy: expected ((x low, x high), (y low, y high)), increasing, got {table_xy!r}")
    b, a, changed = _changed(before, after, threshold)
    old_px = np.stack([project(P, np.r_[xy, table_z + look_height]) for xy in objects_xy])
    shares = changed_shares(changed, old_px, radius_px)
    moved, still = _decided(shares), bool(shares.max() < still_share)
    old_xy = objects_xy[moved if moved >= 0 else target]
    r0, r1, c0, c1 = _object_box(P, old_xy, table_z, object_half_m, object_height_m, changed.shape)
    rows, cols = np.nonzero(changed[r0:r1, c0:c1]) if r1 > r0 and c1 > c0 else (np.zeros(0, int),) * 2
    if len(rows) < min_px:
        return _not_found(moved, "the object's old view did not change", still)
    rows, cols = rows + r0, cols + c0
    centroid = np.array([cols.mean(), rows.mean()])
    height = _height_over(P, centroid, old_xy)
    here = _on_plane(P, centroid, height)

    def scale_of(d: np.ndarray) -> np.ndarray:  # depth there / depth here, the depth P's third row (a pinhole)
        there = _on_plane(P, centroid + d, height)
        return (P[2] @ np.r_[here, height, 1.0]) / (np.c_[there, np.full(len(d), height), np.ones(len(d))] @ P[2])

    def place_of(d: np.ndarray) -> np.ndarray:  # (m, 2) displacements -> (m, 2) where the object then stands
        return old_xy + _on_plane(P, centroid + d, height) - here

    def admissible(d: np.ndarray) -> np.ndarray:
        if table_xy is None:
            return np.ones(len(d), bool)
        xy = place_of(d)
        return ((xy >= bounds[:, 0]) & (xy <= bounds[:, 1])).all(axis=1)

    d, cost = _match_displacement(b, a, changed, rows, cols, _search_radius(P, old_xy, table_z, search_m), scale_of,
                                  admissible, min_changed, cap)
    if cost > max_cost:
        return _not_found(moved, "no displacement of the object's old view matches the view after", still)
    return ScenePlace(moved, place_of(d[None])[0], True, "", still)


def place_reader(frames: np.ndarray, P: np.ndarray, fps: float, first_frame: int, margin: int, rest_s: float = 0.5,
                 height: float = 0.05, min_px_320: int = 20, radius_px_320: float = 5.0, *, table_z: float,
                 table_xy: tuple[tuple[float, float], tuple[float, float]] | None = None):
    """A reader of transfers from one view of a recording (`scene_place`; MAP §VI).

    The scene at rest over `rest_s` seconds ending `margin` frames before the detected start (not
    before `first_frame`; the detected start can be late by the online detector's window), and over the
    last `rest_s` seconds of the recording after the detected end (at least one frame each: at 10 fps a
    person sits still for a few frames before reaching, and tracking starts only as they sit down).
    A movement detected up to the recording's last frame (the recording stopped as the arm came back)
    has no frame after it: the last `rest_s` seconds then count only where they show the scene still
    (a pointing), as every moved object's old view changes; else not found.

    Args:
        frames: (T, H, W, 3) uint8 frames of the view.
        P: (3, 4) the view's camera matrix.
        fps: the recording's frame rate.
        first_frame: the first frame that may count as at rest (e.g. the first segmented one).
        margin: frames left out before the detected start.
        rest_s: the span at rest (s).
        height: above the table top (m), where an object's old position is looked up.
        min_px_320: `scene_place`'s min_px for a 320 x 240 frame, scaled with the frame's size.
        radius_px_320: `scene_place`'s radius_px for a 320 x 240 frame, scaled with the frame's width.
        table_z: the table top's height (world m).
        table_xy: the table top's extent (`scene_place`).

    Returns:
        A function (movement start, end, objects_xy (K, 2), target) -> `ScenePlace`.

    Raises:
        ValueError: `frames` is not (T, H, W, 3), or `fps` is not positive.
    """
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3:
        raise ValueError(f"frames: expected (T, H, W, 3) frames, got {frames.shape}")
    if not fps > 0:
        raise ValueError(f"fps: expected a positive frame rate, got {fps!r}")
    n_frames = len(frames)
    span = max(3, round(rest_s * fps))
    min_px = max(4, round(min_px_320 * frames.shape[1] * frames.shape[2] / (320 * 240)))
    radius = max(2.0, radius_px_320 * frames.shape[2] / 320)

    def read(start: int, end: int, objects_xy: np.ndarray, target: int) -> ScenePlace:
        b1 = start - margin
        b0 = max(first_frame, b1 - span)
        if b1 <= b0:
            return _not_found(-1, "no frame at rest before the movement")

        def place(after: np.ndarray) -> ScenePlace:
            return scene_place(frames[b0:b1], after, P, objects_xy, target, table_z, height, min_px=min_px,
                               radius_px=radius, table_xy=table_xy)

        if end + 1 < n_frames:
            return place(frames[max(end + 1, n_frames - span):])
        # The movement runs to the recording's end (the arm still returning): its last frames, none of the
        # frames at rest before it, can show that nothing was moved, never where something went (the hand
        # may still hold it).
        last = place(frames[max(b1, n_frames - span):])
        if last.still:
            return last
        return _not_found(-1, "no frame at rest after the movement, and its last frames do not show the scene still")

    return read
