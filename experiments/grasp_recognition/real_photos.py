"""Hands found in real photos (GRASP §III-A's front end on real frames): `hog_jax.find_hands` beside the
largest skin blob and a YCrCb rule, scored against true hand boxes.

    python -m experiments.grasp_recognition.real_photos --data ../shared/data --out DIR

Data (`../shared/data`, see its README):
- `gtea_grasps`: 33 real egocentric 640 x 480 frames, 52 labelled hand boxes (wrist to fingertips).
  The upstream frames have the annotation (blue hand boxes, green object boxes, red text) drawn into
  the pixels: `experiments.data.hand_photos.annotation_mask` finds it from the label file's boxes, `green_lines`
  finds the green object boxes from the pixels (they are drawn off the labelled boxes), and it is inpainted
  (OpenCV Telea) before any method sees the frame, so that no drawn line splits or joins a blob.
  Hands the labels leave out (a visible hand with no row) count as false boxes when found.
- `hgr_hands`: real hand photos with skin masks of persons id01-id08; the true box is the bounding box
  of the mask's largest component (the hand with the visible forearm: the masks mark all skin, and
  every photo shows one hand). A method's box counts as the hand at IoU >= 0.5 with it; a hand
  finder's hand boxes cut the forearm off, so its whole-blob box (`HandBoxes.arm_boxes`) is what
  is compared there, and its hand box is scored beside it for the record.

Split (nothing is tuned on the test part): the skin model is `lfd_jax.fit_real_skin_model` (UCI
pixels + HGR persons id01-id03), the skin rules are learnt from the true skin of id01-id03
(`hog_jax.fit_skin_rules`); `HandOptions` were chosen on HGR persons id04-id05 and gtea frames 1-16
(sorted by frame number, 24 hands); the report gives HGR id06-id08 and gtea frames 17-33 (28 hands)
as held out, and all of gtea.

Methods (every one gets the same inpainted frames at the same working resolution):
- `finder`: `hog_jax.find_hands` with `FINDER_OPTIONS` and the fitted rules without their luma floor
  (the floor lost the darker hands of the choosing split);
- `largest_blob`: the current `lfd-jax grasp` front end, `hog_jax.segment` with the same skin model
  (the largest blob after the 3 x 3 median x 3; its square box as `segment` returns it); one box per frame;
- `ycrcb_rule`: the YCrCb rule of Chai & Ngan (1999) (133 <= Cr <= 173, 77 <= Cb <= 127), the same
  median filter, the largest blob's bounding box; one box per frame.

Scoring: `experiments.peers.mediapipe_hands.score_boxes` (greedy one-to-one matching by box IoU, a
hand found at IoU >= 0.5): hands found (recall) and false boxes per frame.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import NamedTuple

import cv2
import jax
import numpy as np

import hog_jax
from experiments.data.hand_photos import (GTEA_DIR, HGR_DIR, annotation_mask, hgr_names, load_photo, person_of,
                                          read_gtea)
from experiments.peers.mediapipe_hands import score_boxes
from experiments.peers.ycrcb import ycrcb_rule
from lfd_common import enable_compilation_cache

FIT_PERSONS = ("id01", "id02", "id03")          # fit_real_skin_model's persons; the rules too
CHOOSE_PERSONS = ("id04", "id05")               # HandOptions chosen on these and on CHOOSE_GTEA
CHOOSE_GTEA = 16                                # the first 16 gtea frames (sorted by frame number)
TEST_PERSONS = ("id06", "id07", "id08")
FINDER_OPTIONS = hog_jax.HandOptions()          # its defaults were chosen on the split above
WORK_SIDE = 320                                 # the working resolution's longer side, every method


class RealFrames(NamedTuple):
    """Real frames with true hand boxes: rgb (H, W, 3) uint8 per frame (sizes may differ), boxes per
    frame (K, 4) int (top, left, bottom, right), bottom and right exclusive, and names."""

    rgb: list
    boxes: list
    names: list


def green_lines(bgr: np.ndarray, length: int = 21) -> np.ndarray:
    """(H, W) bool: the drawn green lines of a gtea frame (the object boxes), grown by 2 px.

    The object boxes are drawn a few pixels off the label file's boxes (and one frame has a box without
    a label row), so they are found from the pixels alone: green well above red and blue (JPEG blurs
    the drawn pure green into the skin it crosses), kept where it runs straight across or down for at
    least `length` pixels (a morphological opening). Green speckle and small green objects go; a
    green area that wide would be inpainted too, which costs no skin.

    Args:
        bgr: (H, W, 3) uint8 BGR frame.
        length: the shortest straight run, in pixels, that counts as a drawn line.

    Returns:
        (H, W) bool, True on the drawn lines and within 2 px of them.
    """
    c = bgr.astype(np.int32)
    green = ((c[..., 1] - np.maximum(c[..., 0], c[..., 2])) > 60).astype(np.uint8)
    lines = (cv2.morphologyEx(green, cv2.MORPH_OPEN, np.ones((1, length), np.uint8))
             | cv2.morphologyEx(green, cv2.MORPH_OPEN, np.ones((length, 1), np.uint8)))
    return cv2.dilate(lines, np.ones((5, 5), np.uint8)) > 0


def load_gtea_clean(data: str | Path) -> RealFrames:
    """The gtea_grasps frames with their annotation inpainted, and their true hand boxes."""
    rgb, boxes, names = [], [], []
    for name, bgr, hands, objects in read_gtea(data):
        drawn = annotation_mask(bgr, hands + objects) | green_lines(bgr)
        clean = cv2.inpaint(bgr, drawn.astype(np.uint8), 3, cv2.INPAINT_TELEA)
        rgb.append(clean[..., ::-1].copy())
        boxes.append(np.array([(y0, x0, y1 + 1, x1 + 1) for x0, y0, x1, y1 in hands], np.int64))
        names.append(name)
    return RealFrames(rgb, boxes, names)


def mask_box(truth: np.ndarray) -> np.ndarray:
    """(1, 4) the bounding box (top, left, bottom, right) of a mask's largest 8-connected component."""
    n, _, stats, _ = cv2.connectedComponentsWithStats(truth.astype(np.uint8), connectivity=8)
    if n <= 1:
        return np.zeros((0, 4), np.int64)
    x, y, w, h = stats[1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA])), :4]
    return np.array([[y, x, y + h, x + w]], np.int64)


def load_hgr(data: str | Path, persons: tuple[str, ...]) -> RealFrames:
    """The HGR photos of `persons` (RGB) and their true boxes (`mask_box` of the skin mask)."""
    photos = [load_photo(data, n) for n in hgr_names(data) if person_of(n) in persons]
    return RealFrames([p.bgr[..., ::-1].copy() for p in photos], [mask_box(p.truth) for p in photos],
                      [p.name for p in photos])


def fit_rules(data: str | Path, persons: tuple[str, ...] = FIT_PERSONS) -> hog_jax.SkinRules:
    """Luma, saturation and texture bounds from the true skin of every HGR photo of `persons` (each
    rule keeps 99 % of it; `hog_jax.fit_skin_rules`), the photos at half size."""
    ims, truths = [], []
    for p in (load_photo(data, n) for n in hgr_names(data) if person_of(n) in persons):
        ims.append(cv2.resize(p.bgr[..., ::-1], None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA))
        truths.append(cv2.resize(p.truth.astype(np.uint8), None, fx=0.5, fy=0.5, interpolation=cv2.INTER_NEAREST) > 0)
    shape = np.max([im.shape[:2] for im in ims], axis=0)
    pad = lambda a, mode: np.pad(a, [(0, shape[0] - a.shape[0]), (0, shape[1] - a.shape[1])] + [(0, 0)] * (a.ndim - 2),
                                 mode=mode)
    frames = np.stack([pad(im, "edge") for im in ims]).astype(np.float32)
    truth = np.stack([pad(t, "constant") for t in truths])
    return hog_jax.fit_skin_rules(frames, truth, ("luma", "saturation", "texture"), 0.01, 5)


def _work(rgb: np.ndarray) -> tuple[np.ndarray, float]:
    """A frame area-averaged to the working resolution (longer side WORK_SIDE), and the scale back."""
    scale = min(1.0, WORK_SIDE / max(rgb.shape[:2]))
    if scale == 1.0:
        return rgb, 1.0
    size = (max(1, round(rgb.shape[1] * scale)), max(1, round(rgb.shape[0] * scale)))
    return cv2.resize(rgb, size, interpolation=cv2.INTER_AREA), 1.0 / scale


def largest_blob_boxes(model: hog_jax.SkinModel, frames: RealFrames) -> list:
    """The current `lfd-jax grasp` front end: `hog_jax.segment`'s largest skin blob, its square box
    (top, left, bottom, right), in each frame's pixels; none where segment finds no skin."""
    out = []
    for rgb in frames.rgb:
        work, back = _work(rgb)
        seg = hog_jax.segment(model, work[None])
        box = np.asarray(seg.boxes)[0] * back
        out.append(box[None] if bool(np.asarray(seg.found)[0]) else np.zeros((0, 4)))
    return out


_ycrcb = jax.jit(lambda x: hog_jax.median3(ycrcb_rule(x), 3))


def ycrcb_boxes(frames: RealFrames) -> list:
    """The YCrCb rule (Chai & Ngan 1999), 3 x 3 median x 3, the largest blob's bounding box."""
    out = []
    for rgb in frames.rgb:
        work, back = _work(rgb)
        mask = np.asarray(_ycrcb(jax.numpy.asarray(work[None], jax.numpy.int32)))[0]
        out.append(mask_box(mask) * back)
    return out


def finder_boxes(model: hog_jax.SkinModel, frames: RealFrames, options: hog_jax.HandOptions) -> tuple[list, list, list]:
    """`hog_jax.find_hands` on each frame: (hand boxes, whole-blob boxes, scores) per frame."""
    hands, arms, scores = [], [], []
    for rgb in frames.rgb:
        r = hog_jax.find_hands(model, rgb[None], options)
        found = np.asarray(r.found)[0]
        hands.append(np.asarray(r.boxes)[0][found])
        arms.append(np.asarray(r.arm_boxes)[0][found])
        scores.append(np.asarray(r.scores)[0][found])
    return hands, arms, scores


def _xy(boxes) -> np.ndarray:
    """(top, left, bottom, right) -> (x0, y0, x1, y1), the order of `score_boxes`."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    return b[:, [1, 0, 3, 2]]


def _score(found: list, truth: list) -> dict:
    s = score_boxes([_xy(f) for f in found], [_xy(t) for t in truth], 0.5)
    return {"hands_found": s["recall"], "false_boxes_per_frame": s["false_boxes_per_frame"],
            "true_boxes": s["true_boxes"], "frames": s["frames"], "mean_best_iou": s["mean_best_iou"]}


def no_hand_crops(frames: RealFrames, rows: int = 200) -> RealFrames:
    """The top `rows` rows of the gtea frames that no true hand box reaches: real kitchen background
    (walls, packaging, jars), no hand."""
    keep = [i for i, b in enumerate(frames.boxes) if not len(b) or b[:, 0].min() >= rows]
    return RealFrames([frames.rgb[i][:rows] for i in keep], [np.zeros((0, 4), np.int64) for _ in keep],
                      [frames.names[i] for i in keep])


def _sheet(frames: RealFrames, methods: dict, title: str, columns: int = 6):
    """Frames with the true boxes (blue) and each method's boxes (its colour), one tile per frame."""
    from experiments.plotting import plt
    colours = {"finder": "lime", "largest_blob": "red", "ycrcb_rule": "orange"}
    n = len(frames.rgb)
    rows = -(-n // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(2.6 * columns, 2.1 * rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for i, ax in enumerate(axes.flat[:n]):
        ax.imshow(frames.rgb[i])
        for t, l, b, r in frames.boxes[i]:
            ax.add_patch(plt.Rectangle((l, t), r - l, b - t, fill=False, color="deepskyblue", lw=1.6))
        for name, boxes in methods.items():
            for t, l, b, r in boxes[i]:
                ax.add_patch(plt.Rectangle((l, t), r - l, b - t, fill=False, color=colours.get(name, "white"), lw=1.0,
                                           ls="-" if name == "finder" else "--"))
        found = len(methods["finder"][i])
        ax.set_title(f"{frames.names[i][-12:]}: {found} hand(s)" if found else f"{frames.names[i][-12:]}: not found",
                     fontsize=7)
    fig.suptitle(f"{title}: true (blue), finder (lime), largest blob (red dashed), YCrCb rule (orange dashed)",
                 fontsize=8)
    fig.tight_layout()
    return fig


def evaluate_real_photos(data: str | Path, model: hog_jax.SkinModel | None = None,
                         options: hog_jax.HandOptions | None = None) -> tuple[dict, dict]:
    """Hands found and false boxes per frame of the finder and the two baselines on real frames.

    Args:
        data: the folder holding `gtea_grasps/`, `hgr_hands/` and the UCI file (`../shared/data`).
        model: the skin model (default `lfd_jax.fit_real_skin_model(data)`).
        options: the finder's `HandOptions` (default `FINDER_OPTIONS` with the rules of `fit_rules`,
            their luma floor off).

    Returns:
        (metrics: {set: {method: {"hands_found", "false_boxes_per_frame", ...}}} for the sets
        gtea_choose, gtea_held_out, gtea_all, hgr_choose, hgr_test and gtea_no_hand (crops without
        hands: "not_found_rate"), figures: {"real_hands_gtea.png", "real_hands_hgr.png"}).
    """
    from lfd_jax import fit_real_skin_model
    t0 = time.perf_counter()
    model = fit_real_skin_model(data) if model is None else model
    if options is None:
        options = FINDER_OPTIONS._replace(rules=fit_rules(data)._replace(min_luma=0.0))
    gtea = load_gtea_clean(data)
    split = lambda f, s: RealFrames(f.rgb[s], f.boxes[s], f.names[s])
    sets = {"gtea_choose": split(gtea, slice(0, CHOOSE_GTEA)), "gtea_held_out": split(gtea, slice(CHOOSE_GTEA, None)),
            "gtea_all": gtea, "hgr_choose": load_hgr(data, CHOOSE_PERSONS), "hgr_test": load_hgr(data, TEST_PERSONS)}
    metrics: dict = {"options": {k: (v._asdict() if hasattr(v, "_asdict") else v) for k, v in options._asdict().items()}}
    shown = {}
    for name, frames in sets.items():
        hands, arms, _ = finder_boxes(model, frames, options)
        blob, ycc = largest_blob_boxes(model, frames), ycrcb_boxes(frames)
        hgr = name.startswith("hgr")
        # HGR's true box is the whole mask (hand and forearm): the finder's whole-blob box is what compares
        metrics[name] = {"finder": _score(arms if hgr else hands, frames.boxes),
                         "largest_blob": _score(blob, frames.boxes), "ycrcb_rule": _score(ycc, frames.boxes)}
        if hgr:
            metrics[name]["finder_hand_box"] = _score(hands, frames.boxes)
        shown[name] = {"finder": arms if hgr else hands, "largest_blob": blob, "ycrcb_rule": ycc}
    empty = no_hand_crops(gtea)
    metrics["gtea_no_hand"] = {
        "crops": len(empty.rgb),
        "finder_not_found_rate": float(np.mean([not len(b) for b in finder_boxes(model, empty, options)[0]])),
        "largest_blob_not_found_rate": float(np.mean([not len(b) for b in largest_blob_boxes(model, empty)])),
        "ycrcb_rule_not_found_rate": float(np.mean([not len(b) for b in ycrcb_boxes(empty)]))}
    metrics["total_s"] = time.perf_counter() - t0
    hgr_test = sets["hgr_test"]
    figures = {"real_hands_gtea.png": _sheet(gtea, shown["gtea_all"], "gtea_grasps (annotation inpainted)"),
               "real_hands_hgr.png": _sheet(hgr_test, shown["hgr_test"], "HGR test persons id06-id08")}
    return metrics, figures


def main(argv=None) -> None:
    """Run `evaluate_real_photos` and write metrics.json and the two contact sheets to --out."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("../shared/data"))
    parser.add_argument("--out", type=Path, default=Path("runs/real_photos"))
    args = parser.parse_args(argv)
    if not (args.data / GTEA_DIR).is_dir() or not (args.data / HGR_DIR).is_dir():
        raise SystemExit(f"real_photos: {args.data} lacks {GTEA_DIR}/ or {HGR_DIR}/ (see ../shared/data/README.md)")
    enable_compilation_cache()
    metrics, figures = evaluate_real_photos(args.data)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    for name, fig in figures.items():
        fig.savefig(args.out / name, dpi=110)
    for key, methods in metrics.items():
        if isinstance(methods, dict) and "finder" in methods:
            print(key, {m: (round(v["hands_found"], 3), round(v["false_boxes_per_frame"], 3)) for m, v in methods.items()})
    print("gtea_no_hand", metrics["gtea_no_hand"])
    print(f"wrote metrics.json and {', '.join(figures)} to {args.out}/ ({metrics['total_s']:.0f} s)")


if __name__ == "__main__":
    main()
