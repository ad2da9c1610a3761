"""Config and presets of the skin segmentation study on real photos."""
from __future__ import annotations

import dataclasses

from lfd_common import check_int, check_real


@dataclasses.dataclass(frozen=True)
class Config:
    """Skin segmentation of real hand photos (HGR1): hog_jax's skin model fitted on the UCI Skin
    Segmentation pixels, beside a fixed YCrCb rule (Chai & Ngan 1999) and OpenCV GrabCut seeded by
    our mask."""

    seed: int = 0
    data: str = "../shared/data"         # holds skin_nonskin_uci.tsv and hgr_hands/ (../shared/data/README.md)
    n_photos: int = 0                    # HGR photos evaluated, evenly spaced over the sorted names (0: all)
    validation_fraction: float = 0.2     # UCI pixels held out to choose the threshold (never the HGR photos)
    n_components: int = 4                # skin mixture components (fit_skin_model's default)
    n_background: int = 4                # background mixture components
    n_iter: int = 100                    # EM iterations of each mixture
    threshold: float | None = None       # log-ratio threshold; none: the IoU-best on the held-out UCI pixels
    curve_thresholds: tuple[float, ...] = (-8.0, -6.0, -4.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0)
    grabcut_iterations: int = 5          # cv2.grabCut iterations from our mask
    hand_iou: float = 0.5                # the largest component "is the hand" at IoU >= this with the true mask
    batch_size: int = 8                  # photos per JAX call (padded to the largest photo's size)
    sheet_photos: int = 6                # rows of the contact sheet
    # the one-model study (study="one_model", presets model_quick / model): experiments/skin_real/one_model.py
    study: str = "uci"                   # "uci": the UCI-fitted model on all HGR photos; "one_model": below
    fit_sources: str = "uci+hgr"         # pixels the one model is fitted on: "uci" or "uci+hgr"
    colour_spaces: tuple[str, ...] = ("crcb", "crcby")  # candidates: (Cr, Cb), (Cr, Cb, Y); chosen on validation
    hgr_fit_ids: tuple[str, ...] = ("id01", "id02", "id03")     # HGR persons fitted on
    hgr_validation_ids: tuple[str, ...] = ("id04", "id05")      # HGR persons the settings are chosen on
    fit_pixels: int = 20000              # pixels sampled per source (UCI: half skin, half not; HGR: as they come)
    uci_validation_pixels: int = 20000   # held-out UCI pixels scored in the validation
    photo_scale: float = 0.5             # HGR photos resized by this (area) before segmenting
    validation_exposures: tuple[float, ...] = (1.0,)  # the validation photos at these RGB scalings (a light check)
    rule_photos: int = 12                # fitting photos the rule bounds are learnt from
    rule_quantile: float = 0.01          # each rule loses at most this share of the true skin on its side
    texture_window: int = 5              # the texture rule's window side
    texture_erode: int = 0               # learn the texture bound on the true skin eroded by this many pixels (0: all)
    thresholds: tuple[float, ...] = (-4.0, -3.0, -2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0)
    relevances: tuple[float, ...] = (4.0, 16.0, 64.0, 256.0, 1024.0)  # candidate MAP relevances of the adaptation
    relevance_tolerance: float = 0.005   # validation IoUs this close to the best count as ties: the larger relevance
    adapt_margin: float = 2.0            # the confident blob: log ratio > threshold + this
    gtea_scale: float = 0.5              # gtea_grasps frames resized by this
    gtea_frames: int = 0                 # gtea frames scored (0: all 33)
    reach_sheet_frames: int = 6          # rows of the reach clip's contact sheet
    static_difference: float = 30.0      # static_skin: the largest per-channel difference from the background

    def __post_init__(self):
        check_int(self.n_photos, "n_photos", min_value=0)
        if not 0.0 < check_real(self.validation_fraction, "validation_fraction") < 1.0:
            raise ValueError(f"validation_fraction: expected a fraction in (0, 1), got {self.validation_fraction}")
        check_int(self.n_components, "n_components", min_value=1)
        check_int(self.n_background, "n_background", min_value=1)
        check_int(self.n_iter, "n_iter", min_value=1)
        if self.threshold is not None:
            check_real(self.threshold, "threshold")
        if not self.curve_thresholds:
            raise ValueError("curve_thresholds: expected at least one threshold")
        check_int(self.grabcut_iterations, "grabcut_iterations", min_value=1)
        check_real(self.hand_iou, "hand_iou", min_value=0.0, max_value=1.0, exclusive_min=True)
        check_int(self.batch_size, "batch_size", min_value=1)
        check_int(self.sheet_photos, "sheet_photos", min_value=1, max_value=20)
        if self.study not in ("uci", "one_model"):
            raise ValueError(f"study: expected 'uci' or 'one_model', got {self.study!r}")
        if self.fit_sources not in ("uci", "uci+hgr"):
            raise ValueError(f"fit_sources: expected 'uci' or 'uci+hgr', got {self.fit_sources!r}")
        if not self.colour_spaces or set(self.colour_spaces) - {"crcb", "crcby"}:
            raise ValueError(f"colour_spaces: expected some of 'crcb', 'crcby', got {self.colour_spaces}")
        if set(self.hgr_fit_ids) & set(self.hgr_validation_ids):
            raise ValueError("hgr_validation_ids: a person both fitted on and validated on")
        for name in ("fit_pixels", "uci_validation_pixels", "rule_photos", "reach_sheet_frames"):
            check_int(getattr(self, name), name, min_value=1)
        check_int(self.gtea_frames, "gtea_frames", min_value=0)
        for name in ("photo_scale", "gtea_scale"):
            check_real(getattr(self, name), name, min_value=0.05, max_value=1.0)
        check_real(self.rule_quantile, "rule_quantile", min_value=0.0, max_value=0.4)
        if not self.validation_exposures or min(self.validation_exposures) <= 0:
            raise ValueError(f"validation_exposures: expected positive scalings, got {self.validation_exposures}")
        if not self.thresholds or not self.relevances:
            raise ValueError("thresholds, relevances: expected at least one value each")


PRESETS = {
    "quick": {"n_photos": 8, "n_iter": 40, "grabcut_iterations": 2, "sheet_photos": 4},
    "paper": {},
    "model_quick": {"study": "one_model", "n_photos": 6, "n_iter": 40, "fit_pixels": 10000,
                    "uci_validation_pixels": 5000, "photo_scale": 0.25, "rule_photos": 4, "gtea_frames": 8,
                    "gtea_scale": 0.25, "relevances": (16.0, 64.0), "reach_sheet_frames": 3},
    "model": {"study": "one_model"},
}
