"""Config and presets of the video segmentation study."""
from __future__ import annotations

import dataclasses

from experiments.data import video
from experiments.data.video import real_sequences
from lfd_common import check_int, check_real


REAL_SEQUENCES = tuple(real_sequences.SEQUENCES)


@dataclasses.dataclass(frozen=True)
class Config:
    """Skin, level-set and tracking segmentation of rendered stereo recordings (LEVELSET TR §3-5, LfD
    2009 §III-A), and the front end on real video: the background model on every real sequence with
    per-frame truth beside OpenCV's MOG2 and KNN, and face and hands tracked on the real reach clip."""

    seed: int = 0
    video_preset: str = "paper"          # experiments.data.video preset of the recordings
    n_skin_persons: int = 2              # persons whose hand and face pixels train the skin models
    eval_repetitions: int = 1            # repetitions per person and OAC evaluated (0: all; 1 keeps the paper preset near 30 min)
    max_clips: int = 0                   # 0: every selected clip of the other persons
    pad_frames: int = 50                 # clips are padded to a multiple of this (one compilation per length)
    motion_penalty: float = 4.0          # VideoOptions: nats off the background where it moves
    object_margin: float = 0.0           # VideoOptions: the object's score above the uniform density
    person_frames: int = 10              # frames before the segmentation starts that teach the person model
    rendered: bool = True                # run the rendered-recordings part
    real: bool = True                    # run the real-video part (each real set skipped, saying so, when absent)
    real_data: str = "../shared/data"    # the real data (../shared/data/README.md)
    real_sequences: tuple[str, ...] = REAL_SEQUENCES  # real_sequences.SEQUENCES names scored
    real_step: int = 1                   # score every real_step-th evaluated frame (every frame is processed)
    real_max_frames: int = 0             # process at most this many frames per sequence (0: all)
    real_person_start: int = 50          # the SBI sequences' first frame segmented by the whole front end
    sheet_frames: int = 12               # frames in the contact sheet

    def __post_init__(self):
        if self.video_preset not in video.PRESETS:
            raise ValueError(f"video_preset: expected one of {sorted(video.PRESETS)}, got {self.video_preset!r}")
        check_int(self.n_skin_persons, "n_skin_persons", min_value=1)
        check_int(self.eval_repetitions, "eval_repetitions", min_value=0)
        check_int(self.max_clips, "max_clips", min_value=0)
        check_int(self.pad_frames, "pad_frames", min_value=1)
        check_real(self.motion_penalty, "motion_penalty", min_value=0.0)
        check_real(self.object_margin, "object_margin")
        check_int(self.person_frames, "person_frames", min_value=1)
        unknown = set(self.real_sequences) - set(real_sequences.SEQUENCES)
        if unknown:
            raise ValueError(f"real_sequences: unknown {sorted(unknown)}; expected names of {sorted(real_sequences.SEQUENCES)}")
        check_int(self.real_step, "real_step", min_value=1)
        check_int(self.real_max_frames, "real_max_frames", min_value=0)
        check_int(self.real_person_start, "real_person_start", min_value=2)
        if not (self.rendered or self.real):
            raise ValueError("rendered, real: at least one part must run")
        check_int(self.sheet_frames, "sheet_frames", min_value=1, max_value=60)

    def video_settings(self) -> video.VideoSettings:
        return video.preset(self.video_preset, seed=self.seed)


PRESETS = {
    "quick": {"video_preset": "quick", "n_skin_persons": 1, "pad_frames": 25, "real_sequences": ("sbi_board",)},
    "paper": {},
    "real_quick": {"rendered": False, "real_step": 4},
    "real": {"rendered": False},
}
