"""The real-photo part of the study, skin: the one skin model of stills and video
(`lfd_jax.fit_real_skin_model`, fitted on UCI pixels and the HGR persons `REAL_SKIN_PERSONS`) beside
the fixed YCrCb rule (`experiments.peers.ycrcb`) on the real hand photos with pixel masks of the HGR
persons it was not fitted on (`experiments.data.hand_photos`), each photo at `SCALE` of its size. Both
masks end in GRASP's 3 x 3 median filter applied three times (`hog_jax.median3`), as the skin model's
masks do everywhere. IoU pooled over the photos and the mean of the per-photo IoUs, per person set:
the persons the model's settings were chosen on (`experiments.skin_real`: id04, id05) and the rest."""
from __future__ import annotations

from pathlib import Path

import jax.numpy as jnp
import numpy as np

from experiments.config import StageResult, progress
from experiments.data.hand_photos import HGR_DIR, hgr_names, hgr_split, load_photo, scaled
from experiments.peers.ycrcb import ycrcb_rule
from hog_jax import median3, skin_log_ratio
from lfd_jax import REAL_SKIN_PERSONS, UCI_FILE, fit_real_skin_model

VALIDATION_PERSONS = ("id04", "id05")  # where experiments.skin_real chose the model's settings
SCALE = 0.5
METHODS = ("ours", "ycrcb")


def photo_masks(model, rgb: np.ndarray) -> dict[str, np.ndarray]:
    """{method: (H, W) bool skin mask} of one RGB photo: the model's log ratio above its threshold and
    the YCrCb rule, each median-filtered."""
    ours = np.asarray(skin_log_ratio(model, rgb)) > float(model.threshold)
    rule = np.asarray(ycrcb_rule(jnp.asarray(np.rint(rgb))))
    return {m: np.asarray(median3(mask[None]))[0] for m, mask in zip(METHODS, (ours, rule))}


def photo_skin_stage(cfg, plots) -> StageResult:
    """Skin IoU per HGR person set and method; skipped, saying so, without the photos."""
    if not ((Path(cfg.real_data) / HGR_DIR / "images").is_dir() and (Path(cfg.real_data) / UCI_FILE).is_file()):
        print(f"note: {Path(cfg.real_data) / HGR_DIR} or {UCI_FILE} not found; the real skin photos are skipped")
        return StageResult({"skin_photos_scored": False})
    model = fit_real_skin_model(cfg.real_data, seed=cfg.seed)
    split = hgr_split(hgr_names(cfg.real_data), REAL_SKIN_PERSONS, VALIDATION_PERSONS)
    metrics = {"skin_photos_scored": True}
    for part in ("validation", "test"):
        inter, union, per_photo = {m: 0 for m in METHODS}, {m: 0 for m in METHODS}, {m: [] for m in METHODS}
        for name in progress(split[part], desc=f"skin photos ({part})"):
            photo = load_photo(cfg.real_data, name)
            rgb, truth = scaled(photo.bgr[..., ::-1].astype(np.float32), SCALE, (photo.truth,))
            for m, mask in photo_masks(model, rgb).items():
                i, u = int(np.sum(mask & truth)), int(np.sum(mask | truth))
                inter[m], union[m] = inter[m] + i, union[m] + u
                per_photo[m].append(i / u if u else 1.0)
        metrics[f"skin_{part}_photos"] = len(split[part])
        for m in METHODS:
            metrics[f"skin_iou_{part}_{m}"] = inter[m] / union[m] if union[m] else float("nan")
            metrics[f"skin_mean_photo_iou_{part}_{m}"] = float(np.mean(per_photo[m])) if per_photo[m] else float("nan")
    return StageResult(metrics)
