"""`lfd-jax video VIDEO --out DIR`: the video front end of `hog_jax.video` (LEVELSET TR §3-5) on
one's own recording, read and processed chunk by chunk so that memory holds one chunk.

What it needs: a video file (an animated GIF too) or a folder of images, and the skin model (fitted on
the real labelled pixels of `--skin-data`, `lfd_jax.fit_real_skin_model`, or read with `--skin-model`).
The background model learns from the first frame on (`VideoOptions.real_video()`: it copes with a person
in view from the start; `--tr-background` for the TR's model and an empty-scene start); what moves in the
`VideoOptions.person_frames` (10) frames before `--start` teaches the person's colour model (TR §3.4-3.5).
Mono: `fit_video_models` on the frames before `--start`, then `hog_jax.video.stream_mono` (segmentation,
the skin blobs tracked as face, hand and other hand, the hands at the far end of bare-forearm blobs);
stereo (`--right`, a rectified pair): `segment_stereo` on the whole pair, also the triangulated
hand-minus-face position.

Writes overlay.mp4 (labels tinted in `lfd_jax.LABEL_COLOURS`: person orange, skin red, object blue; the
tracked face and hands marked), sheet.png (a few overlay frames) and tracks.csv (per frame: the face's and
the hands' positions in pixels and whether each is tracked).
"""
from __future__ import annotations

import csv
import itertools
import time
from pathlib import Path

import cv2
import jax
import numpy as np

import hog_jax
from hog_jax.video import FACE, HAND, OTHER_HAND
from lfd_common import check_int, check_real, enable_compilation_cache, markdown_table
from lfd_jax._src.frames import iter_image_folder, iter_video, load_stereo_videos, video_info
from lfd_jax._src.pictures import LABEL_COLOURS, VideoWriter, overlay, truth_coded
from lfd_jax.cli._src.plotting import plt
from lfd_jax.cli._src.skin import skin_model

MARKED = {FACE: ("face", LABEL_COLOURS[6]), HAND: ("hand", LABEL_COLOURS[5]), OTHER_HAND: ("other hand", LABEL_COLOURS[4])}
SHEET_FRAMES = 8
DEFAULT_FPS = 25.0
MAX_START = 250  # the frames before the segmentation are held in memory to fit the colour models
MIN_AREA_SHARE = 1e-3  # skin blobs below this share of the frame are not tracked (specks)


def resized(chunks, width: int | None):
    """The chunks scaled to `width` (keeping the aspect), or as they are."""
    for frames in chunks:
        if width is None:
            yield frames
            continue
        height = max(1, round(frames.shape[1] * width / frames.shape[2]))
        yield np.stack([cv2.resize(f, (width, height), interpolation=cv2.INTER_AREA) for f in frames])


def clip_chunks(args, chunk: int):
    """The left (or only) video's frames, chunk by chunk, uint8 RGB, scaled to args.width."""
    source = (iter_image_folder(args.video, chunk, args.max_frames) if args.video.is_dir()
              else iter_video(args.video, chunk, args.max_frames, name="video"))
    return resized(source, None if args.width is None else check_int(args.width, "width", min_value=16))


def first_segmented_frame(n_frames: int, start: int | None, options: hog_jax.video.VideoOptions) -> int:
    """`start`, or a third of the clip (at least person_frames + 1, at most `MAX_START`); ValueError
    for a clip too short."""
    shortest = options.person_frames + 2
    if n_frames < shortest:
        raise ValueError(f"video: {n_frames} frames; the pipeline needs at least {shortest} (the scene and the person "
                         f"before --start, then the frames it segments)")
    return min(max(options.person_frames + 1, n_frames // 3), MAX_START) if start is None else start


def count_frames(args) -> int:
    """The frames the run will read (the container's count, else counted by decoding)."""
    info = video_info(args.video, name="video")
    n = info.n_frames if info.n_frames is not None else sum(len(c) for c in clip_chunks(args, 64))
    return n if args.max_frames is None else min(n, args.max_frames)


def draw_targets(frames: np.ndarray, labels: np.ndarray, position: np.ndarray, tracked: np.ndarray) -> np.ndarray:
    """(t, H, W, 3) uint8: the labels tinted over the frames, each tracked target (`MARKED`) marked at
    `position` (t, M, 2) (x, y) where `tracked` (t, M)."""
    out = overlay(frames, truth_coded(labels))
    size = max(6, frames.shape[2] // 30)
    for t in range(len(out)):
        for target, (name, colour) in MARKED.items():
            if tracked[t, target]:
                x, y = np.rint(position[t, target]).astype(int)
                cv2.drawMarker(out[t], (int(x), int(y)), colour.tolist(), cv2.MARKER_CROSS, size, 2)
                cv2.putText(out[t], name, (int(x) + 4, int(y) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.35,
                            colour.tolist(), 1, cv2.LINE_AA)
    return out


def write_sheet(path: Path, frames: list[tuple[int, np.ndarray]]) -> None:
    """The kept overlay frames (index, image) in a 4-column grid."""
    rows = max(1, -(-len(frames) // 4))
    h, w = frames[0][1].shape[:2] if frames else (1, 1)
    fig, axes = plt.subplots(rows, 4, figsize=(16, 16 * rows * h / (4 * w) + 0.3), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, (t, image) in zip(axes.flat, frames):
        ax.imshow(image)
        ax.set_title(f"frame {t}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


TRACK_COLUMNS = ["frame"] + [f"{name.replace(' ', '_')}_{c}" for name, _ in MARKED.values()
                             for c in ("x_px", "y_px", "tracked")]


def track_rows(first: int, position: np.ndarray, tracked: np.ndarray) -> list[list]:
    """tracks.csv rows of a chunk whose first frame is `first`: per target its (x, y) and tracked flag."""
    rows = []
    for t in range(len(position)):
        row = [first + t]
        for target in MARKED:
            row += [f"{position[t, target, 0]:.2f}", f"{position[t, target, 1]:.2f}", int(tracked[t, target])]
        rows.append(row)
    return rows


def run_mono(args, options, skin, fps: float, n_frames: int) -> dict:
    """Fit on the frames before --start, then stream: the overlay, the tracks and the sheet, chunk by chunk."""
    chunk = check_int(args.chunk, "chunk", min_value=1)
    start = first_segmented_frame(n_frames, args.start, options)
    head = np.concatenate(list(itertools.islice(clip_chunks(args, chunk), -(-start // chunk))))[:start]
    models, _ = hog_jax.video.fit_video_models(jax.random.key(0), skin, head, start, options)
    tracking = blob_options(*head.shape[1:3])
    del head
    sheet_at = set(np.unique(np.linspace(start, n_frames - 1, SHEET_FRAMES).round().astype(int)).tolist())
    last = {}

    def remembered(chunks):  # the frames of the chunk whose segmentation is yielded next
        for frames in chunks:
            last["frames"] = frames
            yield frames

    counts, tracked_frames, seen, sheet = np.zeros(len(hog_jax.video.REGIONS) + 1), np.zeros(3), 0, []
    args.out.mkdir(parents=True, exist_ok=True)
    with VideoWriter(args.out / "overlay.mp4", fps) as writer, open(args.out / "tracks.csv", "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(TRACK_COLUMNS)
        for part in hog_jax.video.stream_mono(models, remembered(clip_chunks(args, chunk)), start, options, tracking,
                                               total=n_frames):
            frames = last["frames"]
            position = np.asarray(part.tracks.position, float)
            position[:, [HAND, OTHER_HAND]] = part.hands
            drawn = draw_targets(frames, part.labels, position, part.tracked)
            writer.write(drawn)
            out.writerows(track_rows(seen, position, part.tracked))
            segmented = seen + np.arange(len(frames)) >= start
            counts += np.bincount(part.labels[segmented].ravel() + 1, minlength=len(counts))
            tracked_frames += part.tracked[segmented][:, :3].sum(axis=0)
            sheet += [(seen + i, drawn[i]) for i in range(len(frames)) if seen + i in sheet_at]
            seen += len(frames)
    write_sheet(args.out / "sheet.png", sheet)
    n_segmented = max(seen - start, 1)
    return {"frames": seen, "start": start, "size": frames.shape[1:3],
            "regions": counts[1:] / max(counts.sum(), 1), "tracked": tracked_frames / n_segmented,
            "video": writer.path}


def blob_options(height: int, width: int) -> hog_jax.video.HandFaceOptions:
    """The blob and tracker options for frames of `height` x `width` (skin blobs below `MIN_AREA_SHARE`
    of the frame are specks, not a face or a hand)."""
    return hog_jax.video.HandFaceOptions(min_area=max(4, round(MIN_AREA_SHARE * height * width)))


def run_stereo(args, options, skin, fps: float) -> dict:
    """A rectified pair in memory (`segment_stereo`): the overlay of the left view, the tracks with the
    triangulated hand - face position, the sheet."""
    if args.focal_px is None or args.baseline_m is None:
        raise ValueError("right: a stereo pair needs --focal-px and --baseline-m")
    pair = load_stereo_videos(args.video, args.right, args.max_frames)
    left, right = (np.concatenate(list(resized([v], args.width))) for v in (pair.left, pair.right))
    start = first_segmented_frame(len(left), args.start, options)
    models, _ = hog_jax.video.fit_video_models(jax.random.key(0), skin, left, start, options)
    camera = hog_jax.video.StereoCamera(focal_px=check_real(args.focal_px, "focal_px", min_value=0.0, exclusive_min=True),
                                        baseline_m=check_real(args.baseline_m, "baseline_m", min_value=0.0,
                                                              exclusive_min=True),
                                        width=left.shape[2], height=left.shape[1])
    seg = hog_jax.video.segment_stereo(models, left, right, start, camera, options, blob_options(*left.shape[1:3]))
    labels, tracks = np.asarray(seg.left.labels), seg.positions.skin_left
    position = np.asarray(tracks.position, float)
    tracked = ~np.asarray(tracks.lost) & (np.arange(len(left)) >= start)[:, None]
    drawn = draw_targets(left, labels, position, tracked)
    args.out.mkdir(parents=True, exist_ok=True)
    with VideoWriter(args.out / "overlay.mp4", fps) as writer:
        writer.write(drawn)
    xyz, found = np.asarray(seg.positions.xyz), np.asarray(seg.positions.found_3d)
    with open(args.out / "tracks.csv", "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(TRACK_COLUMNS + ["hand_minus_face_x_m", "hand_minus_face_y_m", "hand_minus_face_z_m", "found_3d"])
        out.writerows(row + [f"{v:.4f}" for v in xyz[t]] + [int(found[t])]
                      for t, row in enumerate(track_rows(0, position, tracked)))
    sheet_at = np.unique(np.linspace(start, len(left) - 1, SHEET_FRAMES).round().astype(int))
    write_sheet(args.out / "sheet.png", [(int(t), drawn[t]) for t in sheet_at])
    counts = np.bincount(labels[start:].ravel() + 1, minlength=len(hog_jax.video.REGIONS) + 1)
    return {"frames": len(left), "start": start, "size": left.shape[1:3], "regions": counts[1:] / max(counts.sum(), 1),
            "tracked": tracked[start:, :3].mean(axis=0), "video": writer.path,
            "found_3d": float(np.mean(found[start:]))}


def run(args) -> int:
    """The `video` subcommand: segment, track, write the overlay, the sheet and the tracks; print a summary."""
    began = time.perf_counter()
    options = hog_jax.video.VideoOptions() if args.tr_background else hog_jax.video.VideoOptions.real_video()
    enable_compilation_cache()
    skin = skin_model(args.skin_model, args.skin_data)
    rate = video_info(args.video, name="video").rate_hz
    fps = check_real(args.fps, "fps", min_value=0.1) if args.fps is not None else rate or DEFAULT_FPS
    if args.right is None:
        result = run_mono(args, options, skin, fps, count_frames(args))
    else:
        result = run_stereo(args, options, skin, fps)
    h, w = result["size"]
    rows = [("frames (segmented from)", f"{result['frames']} ({result['start']})"), ("size", f"{w} x {h}")]
    rows += [(f"{name} pixels", f"{share:.1%}") for name, share in zip(hog_jax.video.REGIONS, result["regions"])]
    rows += [(f"{name} tracked", f"{share:.1%} of the segmented frames")
             for (name, _), share in zip(MARKED.values(), result["tracked"])]
    if "found_3d" in result:
        rows.append(("hand - face found in 3-D", f"{result['found_3d']:.1%}"))
    rows.append(("time", f"{time.perf_counter() - began:.1f} s"))
    print(markdown_table(("quantity", "value"), rows))
    print(f"wrote {result['video']}, {args.out / 'sheet.png'} and {args.out / 'tracks.csv'}")
    return 0
