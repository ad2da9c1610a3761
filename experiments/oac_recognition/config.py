"""Config and presets of the OAC recognition study."""
from __future__ import annotations

import dataclasses

from experiments.data import oac
from experiments.data.oac_protocol import ProtocolOptions


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

    def protocol(self) -> ProtocolOptions:
        """The evaluation protocol's settings (`experiments.data.oac_protocol`)."""
        return ProtocolOptions(seed=self.seed, n_persons=self.n_persons, n_runs=self.n_runs, l2=self.l2,
                               svm_l2=self.svm_l2, n_hidden=self.n_hidden, max_iter=self.max_iter,
                               cooc_smoothing=self.cooc_smoothing)

    def data_settings(self) -> oac.OACSettings:
        return oac.OACSettings(seed=self.seed, n_persons=self.n_persons, n_repetitions=self.n_repetitions,
                               fps=self.fps, image_px=self.image_px)


PRESETS = {
    "quick": {"n_persons": 4, "n_repetitions": 2, "fps": 5.0, "n_runs": 2, "max_iter": 40, "n_hidden": 2},
    "paper": {},
}
