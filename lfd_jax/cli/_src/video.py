"""`lfd-jax video VIDEO --out DIR`: the video front end of `hog_jax.video` (LEVELSET TR §3-5) on
one's own recording, as `experiments.video_segmentation` runs it on rendered ones.

What it needs: a video file (or a folder of images) whose first frames show the scene, then the
person coming in: the Stauffer–Grimson background model learns the frames before `--start`, and
what moves in the last `VideoOptions.person_frames` (10) of them teaches the person's colour model
(TR §3.4-3.5); and skin pixels (the UCI layout, `skin.py`) for the skin GMM. Then
`fit_video_models` -> `segment_recording` (mono) or `segment_stereo` (with `--right`, a rectified
pair: also the triangulated hand-minus-face position) -> the skin blobs tracked as face, hand and
other hand (`hog_jax.video.track`, the acquisition rules of `hog_jax.video.hand_face_positions`).

Writes overlay.mp4 (labels tinted in `lfd_jax.LABEL_COLOURS`: person orange, skin
red, object blue; the tracked face and hand marked), sheet.png (a few overlay frames) and
tracks.csv (per frame: face and hand centroids in pixels and whether each is tracked).
"""
from __future__ import annotations

import csv
import time
from pathlib import Path

import cv2
import jax
import numpy as np

import hog_jax
from lfd_jax.cli._src.skin import video_skin_gmm
from lfd_common import markdown_table, progress
from lfd_jax._src.frames import load_image_folder, load_stereo_videos, load_video
from lfd_jax._src.pictures import LABEL_COLOURS, overlay, truth_coded, write_video
from lfd_jax.cli._src.plotting import plt
from hog_jax.video import FACE, HAND
from lfd_common import check_int, check_real, enable_compilation_cache

SKIN_TARGETS = ("top", "left_of_first", "right_of_first")  # face, hand, other hand: hog_jax.video.hand_face_positions' default rules
MARKED = {FACE: ("face", LABEL_COLOURS[6]), HAND: ("hand", LABEL_COLOURS[5])}
SHEET_FRAMES = 8
DEFAULT_FPS = 25.0


def read_clip(args) -> tuple[np.ndarray, np.ndarray | None, float | None]:
    """(left (T, H, W, 3) uint8 RGB, right or None, frame rate or None), scaled to args.width."""
    if args.right is not None:
        pair = load_stereo_videos(args.video, args.right, args.max_frames)
        left, right, rate = pair.left, pair.right, pair.rate_hz
    else:
        clip = load_image_folder(args.video, args.max_frames) if args.video.is_dir() else load_video(
            args.video, args.max_frames)
        left, right, rate = clip.frames, None, clip.rate_hz
    if args.width is not None:
        width = check_int(args.width, "width", min_value=16)
        height = max(1, round(left.shape[1] * width / left.shape[2]))
        resize = lambda frames: np.stack([cv2.resize(f, (width, height), interpolation=cv2.INTER_AREA) for f in frames])
        left, right = resize(left), None if right is None else resize(right)
    return left, right, rate


def first_segmented_frame(n_frames: int, start: int | None, options: hog_jax.video.VideoOptions) -> int:
    """`start`, or a third of the clip (at least person_frames + 1); ValueError for a clip too short."""
    shortest = options.person_frames + 2
    if n_frames < shortest:
        raise ValueError(f"video: {n_frames} frames; the pipeline needs at least {shortest} (the scene and the person "
                         f"entering before --start, then the frames it segments)")
    return max(options.person_frames + 1, n_frames // 3) if start is None else start


def segment_and_track(args, left, right, start: int, options: hog_jax.video.VideoOptions):
    """(labels (T, H, W) in `hog_jax.video.REGIONS` order, skin `Tracks` of the left view (M = 3), the
    `HandFacePositions` of a stereo pair or None)."""
    key = jax.random.key(0)
    bar = progress(total=3, desc="skin model")
    skin = video_skin_gmm(args.skin_data)
    bar.update()
    bar.set_description("colour models")
    models, _ = hog_jax.video.fit_video_models(key, skin, left, start, options)
    bar.update()
    bar.set_description("level sets and tracking")
    if right is None:
        labels = np.asarray(hog_jax.video.segment_recording(models, left, start, options).labels)
        blobs = hog_jax.video.connected_blobs(labels == hog_jax.video.REGIONS.index("skin"), max_blobs=8, min_area=4)
        tracks, positions = hog_jax.video.track(blobs, SKIN_TARGETS, hog_jax.video.TrackOptions(min_init=2)), None
    else:
        camera = hog_jax.video.StereoCamera(focal_px=args.focal_px, baseline_m=args.baseline_m, width=left.shape[2],
                                      height=left.shape[1])
        tracking = hog_jax.video.HandFaceOptions(init=SKIN_TARGETS, tracking=hog_jax.video.TrackOptions(min_init=2))
        seg = hog_jax.video.segment_stereo(models, left, right, start, camera, options, tracking)
        labels, positions = np.asarray(seg.left.labels), seg.positions
        tracks = positions.skin_left
    bar.update()
    bar.close()
    return labels, tracks, positions


def tracking_overlay(frames: np.ndarray, labels: np.ndarray, tracks) -> np.ndarray:
    """(T, H, W, 3) uint8: the labels tinted over the frames, the tracked face and hand marked."""
    out = overlay(frames, truth_coded(labels))
    position, lost = np.asarray(tracks.position), np.asarray(tracks.lost)
    size = max(6, frames.shape[2] // 30)
    for t in range(len(out)):
        for target, (name, colour) in MARKED.items():
            if not lost[t, target]:
                x, y = np.rint(position[t, target]).astype(int)
                cv2.drawMarker(out[t], (int(x), int(y)), colour.tolist(), cv2.MARKER_CROSS, size, 2)
                cv2.putText(out[t], name, (int(x) + 4, int(y) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.35,
                            colour.tolist(), 1, cv2.LINE_AA)
    return out


def write_sheet(path: Path, frames: np.ndarray, start: int) -> None:
    """SHEET_FRAMES overlay frames from `start` on, in a 4-column grid."""
    index = np.unique(np.linspace(start, len(frames) - 1, SHEET_FRAMES).round().astype(int))
    rows = -(-len(index) // 4)
    fig, axes = plt.subplots(rows, 4, figsize=(16, 16 * rows * frames.shape[1] / (4 * frames.shape[2]) + 0.3),
                             squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, t in zip(axes.flat, index):
        ax.imshow(frames[t])
        ax.set_title(f"frame {t}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def write_tracks(path: Path, tracks, positions) -> None:
    """tracks.csv: per frame the face's and the hand's centroid (px) and tracked flag; with a stereo
    pair also the triangulated hand - face (m, left camera frame) and whether it was found in 3-D."""
    position, lost = np.asarray(tracks.position), np.asarray(tracks.lost)
    header = ["frame", "face_x_px", "face_y_px", "face_tracked", "hand_x_px", "hand_y_px", "hand_tracked"]
    if positions is not None:
        header += ["hand_minus_face_x_m", "hand_minus_face_y_m", "hand_minus_face_z_m", "found_3d"]
        xyz, found_3d = np.asarray(positions.xyz), np.asarray(positions.found_3d)
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(header)
        for t in range(len(position)):
            row = [t]
            for target in (FACE, HAND):
                row += [f"{position[t, target, 0]:.2f}", f"{position[t, target, 1]:.2f}", int(not lost[t, target])]
            if positions is not None:
                row += [f"{v:.4f}" for v in xyz[t]] + [int(found_3d[t])]
            out.writerow(row)


def run(args) -> int:
    """The `video` subcommand: segment, track, write the overlay, the sheet and the tracks; print a summary."""
    began = time.perf_counter()
    if args.right is not None and (args.focal_px is None or args.baseline_m is None):
        raise ValueError("right: a stereo pair needs --focal-px and --baseline-m")
    left, right, rate = read_clip(args)
    options = hog_jax.video.VideoOptions()
    start = first_segmented_frame(len(left), args.start, options)
    fps = check_real(args.fps, "fps", min_value=0.1) if args.fps is not None else rate or DEFAULT_FPS
    enable_compilation_cache()
    labels, tracks, positions = segment_and_track(args, left, right, start, options)
    args.out.mkdir(parents=True, exist_ok=True)
    frames = tracking_overlay(left, labels, tracks)
    video_path = write_video(frames, args.out / "overlay.mp4", fps=fps)
    write_sheet(args.out / "sheet.png", frames, start)
    write_tracks(args.out / "tracks.csv", tracks, positions)
    segmented, lost = labels[start:], np.asarray(tracks.lost)[start:]
    rows = [("frames (segmented from)", f"{len(left)} ({start})"), ("size", f"{left.shape[2]} x {left.shape[1]}")]
    rows += [(f"{name} pixels", f"{np.mean(segmented == r):.1%}") for r, name in enumerate(hog_jax.video.REGIONS)]
    rows += [(f"{name} tracked", f"{np.mean(~lost[:, target]):.1%} of the segmented frames")
             for target, (name, _) in MARKED.items()]
    if positions is not None:
        rows.append(("hand - face found in 3-D", f"{np.mean(np.asarray(positions.found_3d)[start:]):.1%}"))
    rows.append(("time", f"{time.perf_counter() - began:.1f} s"))
    print(markdown_table(("quantity", "value"), rows))
    print(f"wrote {video_path}, {args.out / 'sheet.png'} and {args.out / 'tracks.csv'}")
    return 0
