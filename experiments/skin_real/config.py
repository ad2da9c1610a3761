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


PRESETS = {
    "quick": {"n_photos": 8, "n_iter": 40, "grabcut_iterations": 2, "sheet_photos": 4},
    "paper": {},
}
