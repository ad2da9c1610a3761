"""Config and presets of the learning-from-demonstration study."""
from __future__ import annotations

import dataclasses

from experiments.data import video
from lfd_common import check_int, check_real


@dataclasses.dataclass(frozen=True)
class Config:
    """The long unsegmented recordings through the video front end, the object in the hand
    from phase differences (LfD 2009 §III-B) beside an OpenCV peer, and pick-up / put-down events
    (§III-D, Fig. 8). Settings at 320 x 240 scale with the image width."""

    seed: int = 0
    video_preset: str = "paper"        # experiments.data.video preset of the recordings
    n_scripts: int = 0                 # long recordings (script i by person i); 0: the video preset's (paper: 2)
    script_oacs: int = 0               # OACs per recording (at least the 2 unseen ones); 0: the video preset's
    n_skin_persons: int = 2            # the last persons' clips train the skin models (no script is theirs)
    pad_frames: int = 50               # recordings are padded to a multiple of this (one compilation per length)
    half_window: int = 20              # the hand's window, (2 h + 1)^2 pixels at 320 x 240 (LfD §III-B, assumption 1)
    blur_sigma: float = 2.0            # Gaussian blur before the phase, px at 320 x 240
    threshold: float = 0.01            # log r_m r_s > threshold (the paper's exp(0.01))
    n_samples: int = 100               # eq. 4's N random disparities
    min_hand_motion: float = 2.0       # px at 320 x 240: a frame decides only where the hand moved (README)
    remove_person: bool = False        # also remove the pixels the level sets call person (the paper: the hand's only)
    filter_radius: int = 1             # the closing and opening over time (frames at 25 fps)
    min_duration_s: float = 1.0        # shorter "object in hand" periods are removed (LfD §III-D)
    event_tolerance_s: float = 2.0     # a found period matches a true one it overlaps; errors beyond this are flagged
    n_persons: int = 0                 # persons of the video preset; 0: the preset's (clips need 3 + skin persons)
    clip_repetitions: int = 1          # clips per person and OAC through the front end (the paper: 5; ~1.5 min each)
    feature_fps: float = 10.0          # OAC features resampled to this rate (the OAC study's)
    n_runs: int = 9                    # jackknife runs of the OAC tables (LfD: 9, median (max))
    crf_max_iter: int = 100            # L-BFGS iterations of every CRF (early stopping on a validation person)
    n_hidden: int = 3                  # HCRF hidden states per class
    history_distance_px: float = 20.0  # eq. 10's default distance delta_0, px at 320 x 240

    def __post_init__(self):
        if self.video_preset not in video.PRESETS:
            raise ValueError(f"video_preset: expected one of {sorted(video.PRESETS)}, got {self.video_preset!r}")
        for name, low in (("n_scripts", 0), ("script_oacs", 0), ("n_skin_persons", 1), ("pad_frames", 1),
                          ("half_window", 2), ("n_samples", 1), ("filter_radius", 0), ("n_persons", 0),
                          ("clip_repetitions", 0), ("n_runs", 1), ("crf_max_iter", 1), ("n_hidden", 1)):
            check_int(getattr(self, name), name, min_value=low)
        for name in ("blur_sigma", "min_duration_s", "event_tolerance_s", "feature_fps", "history_distance_px"):
            check_real(getattr(self, name), name, min_value=0.0, exclusive_min=True)
        check_real(self.threshold, "threshold")
        check_real(self.min_hand_motion, "min_hand_motion", min_value=0.0)
        if not isinstance(self.remove_person, bool):
            raise ValueError(f"remove_person: expected a bool, got {self.remove_person!r}")

    def video_settings(self) -> video.VideoSettings:
        overrides = {k: getattr(self, k) for k in ("n_scripts", "script_oacs", "n_persons") if getattr(self, k)}
        settings = video.preset(self.video_preset, seed=self.seed, **overrides)
        if settings.n_scripts < 1:
            raise ValueError(f"n_scripts: the video preset {self.video_preset!r} has no long recording")
        if settings.n_scripts + self.n_skin_persons > settings.n_persons:
            raise ValueError(f"n_skin_persons: {self.n_skin_persons} skin persons and {settings.n_scripts} scripts "
                             f"need more than the preset's {settings.n_persons} persons")
        if self.clip_repetitions and settings.n_persons - self.n_skin_persons < 3:
            raise ValueError(f"n_persons: the OAC tables need 3 clip persons (test, validation, training) besides the "
                             f"{self.n_skin_persons} skin person(s); the preset has {settings.n_persons} persons")
        if self.clip_repetitions > settings.n_repetitions:
            raise ValueError(f"clip_repetitions: the video preset has {settings.n_repetitions} clips per person and "
                             f"OAC, got {self.clip_repetitions}")
        return settings

    def clip_persons(self, settings: video.VideoSettings) -> range:
        """The persons whose clips make the OAC tables and train the CHCRF (the skin persons are last)."""
        return range(settings.n_persons - self.n_skin_persons)

    def scale(self, settings: video.VideoSettings) -> float:
        """Image width over 320: lengths in pixels are given at 320 x 240."""
        return settings.width / 320.0


PRESETS = {
    "quick": {"video_preset": "quick", "n_scripts": 0, "n_skin_persons": 1, "pad_frames": 25, "n_persons": 4,
              "clip_repetitions": 1, "n_runs": 2, "crf_max_iter": 40, "n_hidden": 2},
    "paper": {},
}
