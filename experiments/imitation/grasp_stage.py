"""The imitation loop's grasp stage (GRASP §III-V): the demonstrating hand's crop at the grasp moment
and its grasp class by eq. 3's kNN over HOG (`lfd_jax.grasp`), from one of two databases:

- "study": the grasp recognition study's rendered hand views (the database of its preset
  `cfg.grasp_preset`, `experiments.data.grasp_database.DATABASE_PRESETS`, optionally degraded to
  `cfg.grasp_db_pixels`), GRASP's recogniser on it (`RecogniserOptions` defaults); orientation by eq. 4.
- "demonstrations": hand crops cut the same way from transfer demonstrations of their own seed (never
  the evaluated or the validation ones), around each one's pick-up frame, labelled with its grasp; the
  class by eq. 3's kNN or (`cfg.grasp_classifier` "cnn") by a convnet trained on them. No orientation
  (the crops carry none): the quaternion is NaN.

Why both: at 320 x 240 the demonstrating hand is about 16 pixels across, its crop holds part of the
wrist and the object, and the study's views (a bare hand, 64 pixels, every direction of the upper half
sphere) recognise it below chance on validation crops (`experiments/validation/imitation_grasp.py`).

Where the crops come from (`hand_views`): the left view, cut at the tracked hand, or with
`cfg.fovea_px` a foveal camera turned to the tracked hand (`fovea`), rendered at the grasp moment: the
hand then spans tens of pixels whatever the wide cameras' resolution."""
from __future__ import annotations

import contextlib

import jax
import numpy as np

import hog_jax
from experiments.config import progress
from experiments.data import video
from experiments.data.grasp_database import DATABASE_PRESETS, DatabaseOptions, database
from experiments.imitation.config import Config
from experiments.imitation.demonstrations import DEMO_PACKAGES, Demo, draw_demos, render_demo
from experiments.imitation.fovea import Fovea, fovea_rig
from lfd_common import Cache
from lfd_jax.grasp import (Crops, Recogniser, RecogniserOptions, build_recogniser, cached_convnet, crops_of, features,
                           fit_convnet, hog_config, hog_features, net_labels, recognise, transformed)
from lfd_jax.imitation import camera_rotation
from sim.grasping import GRASP_CLASSES
from sim.scenes import PART_NAMES

_GRASP_SEED = 3000  # the demonstrations of the "demonstrations" database (PHMMs: 2000, validation: 1000)


def hand_crop(frames: np.ndarray, hand_rc, skin, out_size: int, window: int = 0) -> Crops:
    """The skin-segmented hand crops (`lfd_jax.grasp.Crops`: images (B, S, S), masks, found (B,), the
    unmasked boxes) at the tracked hand (row, col) (B, 2) of each of `frames` (B, H, W, 3) (GRASP §III-A);
    `window` > 0: only skin within that many pixels (a square) of the hand, so that a skin-coloured
    sleeve or jacket joined to the hand does not become the crop."""
    frames = np.asarray(frames)
    rc = np.asarray(hand_rc, np.float32).reshape(-1, 2)
    if window:
        corner = np.rint(rc).astype(int) - window                   # of each window, in frame pixels
        padded = np.pad(frames, ((0, 0), (window, window), (window, window), (0, 0)))
        offsets = np.arange(2 * window + 1)
        rows = (corner[:, 0, None] + window + offsets)[:, :, None]
        cols = (corner[:, 1, None] + window + offsets)[:, None, :]
        frames = padded[np.arange(len(frames))[:, None, None], rows, cols]
        rc = rc - corner
    return crops_of(hog_jax.segment(skin, frames, seed_points=rc, out_size=out_size))


def crop_window(cfg: Config, settings: video.VideoSettings) -> int:
    """`cfg.grasp_window_frac` of the frame width in pixels (0: no window)."""
    return round(cfg.grasp_window_frac * settings.width)


def hand_views(cfg: Config, settings: video.VideoSettings, demo: Demo, rec: video.Recording, frames,
               hand_rc) -> tuple[np.ndarray, np.ndarray, int]:
    """What the hand is cropped from at each of `frames` (B,), given the tracked hand (row, col) (B, 2)
    in the left view: (images (B, H, W, 3), the hand (row, col) in them (B, 2), the crop window in their
    pixels (`hand_crop`)). The left view with `crop_window`, or with `cfg.fovea_px` the foveal camera
    (`fovea.Fovea`) aimed at the tracked hand, the hand at its centre, no window (the fovea's narrow
    field keeps the skin far from the hand out)."""
    frames, rc = np.asarray(frames, int).reshape(-1), np.asarray(hand_rc, np.float32).reshape(-1, 2)
    if not cfg.fovea_px:
        return rec.left[frames], rc, crop_window(cfg, settings)
    with Fovea(settings, cfg.fovea_px, cfg.fovea_fov_deg) as fovea:
        images = np.stack([fovea.view(demo, int(f), rec.P_left, x)[0] for f, x in zip(frames, rc)])
    return images, np.full((len(frames), 2), (cfg.fovea_px - 1) / 2, np.float32), 0


def database_options(cfg: Config) -> DatabaseOptions:
    """The view database of the grasp study's preset `cfg.grasp_preset`, with cfg's seed and
    `grasp_db_pixels`."""
    if cfg.grasp_preset not in DATABASE_PRESETS:
        raise ValueError(f"grasp_preset: expected one of {sorted(DATABASE_PRESETS)}, got {cfg.grasp_preset!r}")
    return DatabaseOptions(**{**DATABASE_PRESETS[cfg.grasp_preset], "seed": cfg.seed, "db_pixels": cfg.grasp_db_pixels})


def _pickup_views(cfg: Config, settings: video.VideoSettings, demo: Demo, shifts: np.ndarray, fovea: Fovea | None):
    """(views, hand (row, col) in them, window) of `hand_views` at the demonstration's pick-up frame
    shifted by each of `shifts` where the hand is visible, aimed at the renderer's hand: in the left view
    its centroid; the fovea at its centre of volume, without the left view rendered."""
    if fovea is None:
        rec = render_demo(settings, demo)
        frames = np.unique(np.clip(rec.pickup_frames[0] + shifts, 0, len(rec.left) - 1))
        frames = frames[rec.ellipse_found[frames, 0, 0]]
        return hand_views(cfg, settings, demo, rec, frames, rec.ellipse_centre[frames, 0, 0, ::-1])
    track = fovea.movement(demo)
    frames = np.unique(np.clip(track.pickups[0] + shifts, 0, len(track.light) - 1))
    camera = fovea.actors(demo).rig.projection_matrices()[0]
    views = [fovea.view(demo, int(f), camera, fovea.hand_rc(demo, int(f), camera)) for f in frames]
    images = np.stack([v[0] for v in views])[[(v[1] == PART_NAMES.index("hand")).any() for v in views]]
    return images, np.full((len(images), 2), (cfg.fovea_px - 1) / 2, np.float32), 0


# What the crops depend on besides their arguments: the rendering of the demonstrations, the fovea (and the
# actors it takes from `pipeline`), this module and the skin segmentation.
_CROPS = Cache("imitation_grasp_crops", packages=DEMO_PACKAGES + (
    "experiments.imitation.fovea", "experiments.imitation.pipeline", "experiments.imitation.grasp_stage", "hog_jax"),
    compress=True)


def demonstration_crops(cfg: Config, settings: video.VideoSettings, chroma_skin, n: int, seed: int):
    """Hand crops of n transfer demonstrations drawn with `seed`, at their pick-up frame shifted by each
    of `cfg.grasp_frames_s`, from the views of `hand_views` aimed at the renderer's hand (the tracker
    taken out): (`lfd_jax.grasp.Crops` of N crops, grasp classes (N,), demonstration index (N,)), in the
    demonstrations' order. Cached under the project cache (`imitation_grasp_crops`)."""
    crop_size = database_options(cfg).crop_size
    demos = draw_demos(n, seed, cfg.demonstrators, cfg.handover_xy, kinds=("transfer",))
    shifts = np.array(sorted({round(s * settings.fps) for s in cfg.grasp_frames_s}))

    def compute():
        crops = {}
        with Fovea(settings, cfg.fovea_px, cfg.fovea_fov_deg) if cfg.fovea_px else contextlib.nullcontext() as fovea:
            # person by person: the fovea compiles one person's scene at a time (3x faster for 1000 demos)
            for i in sorted(range(n), key=lambda i: demos[i].person):
                views, rc, window = _pickup_views(cfg, settings, demos[i], shifts, fovea)
                if len(views):
                    crops[i] = (*hand_crop(views, rc, chroma_skin, crop_size, window),
                                np.full(len(views), demos[i].grasp), np.full(len(views), i))
        if not crops:
            raise ValueError(f"n: no hand visible at the pick-up of the {n} demonstrations")
        return tuple(np.concatenate(parts) for parts in zip(*(crops[i] for i in sorted(crops))))

    *parts, grasps, index = _CROPS.get(compute, settings=settings, skin=chroma_skin, demos=demos, shifts=shifts,
                                       crop_size=crop_size, fovea=(cfg.fovea_px, cfg.fovea_fov_deg),
                                       window=crop_window(cfg, settings))
    return Crops(*parts), grasps, index


def grasp_recogniser(cfg: Config, settings: video.VideoSettings, chroma_skin):
    """(database options, `lfd_jax.grasp.Recogniser`) of `cfg.grasp_database`."""
    dcfg, options = database_options(cfg), RecogniserOptions(seed=cfg.seed)
    if cfg.grasp_database == "study":
        db = database(dcfg, progress=lambda it, total, d: progress(it, desc=d, total=total))
        return dcfg, build_recogniser(options, jax.random.key(cfg.seed), db, None)
    crops, grasps, _ = demonstration_crops(cfg, settings, chroma_skin, cfg.grasp_train_demos, cfg.seed + _GRASP_SEED)
    found = crops.found
    hcfg = hog_config(options)
    x = hog_features(crops.images, crops.masks, found, hcfg)[found]
    labels = np.array([GRASP_CLASSES.index(g) for g in grasps[found]])
    metric = hog_jax.fit_metric(x, labels, shrinkage=cfg.grasp_lda_shrinkage) if cfg.grasp_metric == "lda" else None
    model = hog_jax.fit(transformed(metric, x), labels, n_classes=len(GRASP_CLASSES), seed=cfg.seed)
    net = None
    if cfg.grasp_classifier in ("cnn", "scene_cnn"):
        train = crops.take(found)
        context = train.context if cfg.grasp_classifier == "scene_cnn" else None
        data = (train.images, train.masks, labels)
        net = cached_convnet(dict(crops=data, seed=cfg.seed, epochs=cfg.grasp_cnn_epochs), lambda: fit_convnet(
            *data, len(GRASP_CLASSES), cfg.seed, epochs=cfg.grasp_cnn_epochs, context=context,
            progress=lambda it, total: progress(it, desc="grasp convnet", total=total)), context=context is not None)
    return dcfg, Recogniser(hcfg, metric, model, {}, None, options.k, None, net)


def grasp_function(cfg: Config, models_grasp, chroma_skin, demo: Demo, rec: video.Recording, hand_rc: np.ndarray,
                   settings: video.VideoSettings):
    """frame -> (grasp class, quaternion) of the hand crop at that frame of the demonstration's
    recording, from the view of `hand_views` aimed at `hand_rc` (T, 2) (row, col) of the tracked hand
    (-1 and NaN where no hand is found; NaN quaternion from the "demonstrations" database)."""
    dcfg, recogniser = models_grasp

    def at(frame: int):
        views, rc, window = hand_views(cfg, settings, demo, rec, [frame], hand_rc[frame])
        crops = hand_crop(views, rc, chroma_skin, dcfg.crop_size, window)
        if not crops.found.any():
            return -1, np.full(4, np.nan)
        net = net_labels(recogniser, crops)  # None without a network
        out = recognise(recogniser, features(recogniser, crops.images, crops.masks, crops.found), crops.found,
                        exact=True, labels=net)
        label = int(out.labels[0])
        quat = out.quat[0] if cfg.grasp_database == "study" else np.full(4, np.nan)
        return (GRASP_CLASSES[label] if label >= 0 else -1), quat

    return at


def view_rotation(cfg: Config, rec: video.Recording, hand_rc: np.ndarray) -> np.ndarray:
    """The world -> camera rotation (camera axes x right, y down, z forward) of the view `hand_views` cuts
    the hand from when the tracked hand is at `hand_rc` (2,) (row, col) in the left view: the left camera's,
    or with `cfg.fovea_px` the foveal camera's turned to that pixel (`fovea.fovea_rig`). The frame in which
    eq. 4's orientation is recognised (`lfd_jax.imitation.hand_rotation`)."""
    if not cfg.fovea_px:
        return camera_rotation(rec.P_left)
    return np.asarray(fovea_rig(rec.P_left, hand_rc, cfg.fovea_px, cfg.fovea_fov_deg).rotation, float).T


__all__ = ["crop_window", "database_options", "demonstration_crops", "grasp_function", "grasp_recogniser", "hand_crop",
           "hand_views", "view_rotation"]
