"""Config, presets and the papers' numbers of the OAC recognition study."""
from __future__ import annotations

import dataclasses

from experiments.data import oac

PAPER_TABLE2 = {
    "actions": {"crf_conn0": (5.3, 9.3), "crf_conn1": (6.0, 12.7), "crf_conn2": (10.7, 18.7),
                "hcrf_conn0": (14.7, 21.3), "baseline": (17.3, 20.0)},
    "objects": {"crf_conn0": (8.0, 8.7), "crf_conn1": (11.3, 13.3), "crf_conn2": (20.7, 28.0),
                "hcrf_conn0": (24.7, 28.7), "baseline": (8.7, None)},
}
PAPER_TABLE3 = {"actions": {"chcrf": (3.3, 4.7), "fcrf": (5.3, 8.0), "separate_crf": (5.3, 9.3)},
                "objects": {"chcrf": (3.3, 4.7), "fcrf": (6.0, 12.0), "separate_crf": (8.0, 8.7)}}
PAPER_TABLE4 = {"xa_xo": (3.3, 4.7), "pa_xo": (2.7, 8.0), "xa_x1o": (4.7, 8.7), "pa_x1o": (14.7, 18.0)}
PAPER_LFD_CORRECT = {"2d": {"shape_and_pos": 95.3, "pos_only": 80.0}, "3d": {"shape_and_pos": 95.3, "pos_only": 85.3}}
TABLE4_CELLS = {  # cell -> (action classifier, object classifier)
    "xa_xo": ("crf_conn0", "crf_conn0"), "pa_xo": ("baseline_pos2d", "crf_conn0"),
    "xa_x1o": ("crf_conn0", "baseline_first_frame"), "pa_x1o": ("baseline_pos2d", "baseline_first_frame"),
}


@dataclasses.dataclass(frozen=True)
class Config:
    """OAC action-object recognition on simulated recordings (ECCV 2008 Tables 2-4, LfD 2009 Table I)."""

    seed: int = 0
    n_persons: int = 10
    n_repetitions: int = 5
    fps: float = 10.0
    image_px: int = 48
    n_runs: int = 9
    l2: float = 1.0                 # CRFsuite's c2 for every CRF
    svm_l2: float = 0.01
    n_hidden: int = 3               # HCRF hidden states per class
    max_iter: int = 100             # L-BFGS iterations (early stopping on the validation person)
    cooc_smoothing: float = 0.01    # K(a, o) = (count + smoothing) / sum

    def __post_init__(self):
        if self.n_persons < 3:
            raise ValueError("n_persons: need at least 3 (test, validation and training persons)")
        if self.n_repetitions < 1 or self.n_runs < 1 or self.max_iter < 1 or self.n_hidden < 1:
            raise ValueError("n_repetitions, n_runs, max_iter and n_hidden must be positive")
        if self.l2 < 0 or self.svm_l2 < 0 or self.cooc_smoothing < 0:
            raise ValueError("l2, svm_l2 and cooc_smoothing must be >= 0")

    def data_settings(self) -> oac.OACSettings:
        return oac.OACSettings(seed=self.seed, n_persons=self.n_persons, n_repetitions=self.n_repetitions,
                               fps=self.fps, image_px=self.image_px)


PRESETS = {
    "quick": {"n_persons": 4, "n_repetitions": 2, "fps": 5.0, "n_runs": 2, "max_iter": 40, "n_hidden": 2},
    "paper": {},
}
