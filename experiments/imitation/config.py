"""Config and presets of the imitation loop."""
from __future__ import annotations

import dataclasses

from experiments.data import video
from lfd_common import check_int, check_real


@dataclasses.dataclass(frozen=True)
class Config:
    """Demonstrations (rendered), the video front end, the online PHMMs, the grasp recogniser and the
    robot. Settings marked "validation" are chosen on demonstrations of their own seed
    (`seed + VALIDATION_SEED`), never on the evaluated ones."""

    seed: int = 0
    video_preset: str = "paper"          # experiments.data.video preset (resolution, frame rate, timing)
    n_persons: int = 4                   # persons of the video settings; the last n_skin_persons train the skin models
    n_skin_persons: int = 1
    n_demos: int = 100                   # evaluated demonstrations
    n_videos: int = 4                    # side-by-side videos (the person | the robot) of the first n_videos of them
    n_validation: int = 6                # validation demonstrations (own seed): feature offset, noise, threshold
    pad_frames: int = 25                 # recordings padded to a multiple of this (one compilation per length)
    # the level sets' coarse scale (TR §5; from 240 x 320 up) loses the hand held out from the body: off,
    # chosen on validation demonstrations (the 3-D hand found in the reach and carry)
    coarse_scale: bool = False
    # the smallest skin blob tracked, in pixels of a 160 x 120 frame (scaled with the frame's area): at
    # 320 x 240 a 5-pixel speck on the head was the highest skin blob and became the "face"
    min_blob_px_160: int = 4
    handover_xy: tuple[float, ...] = (-0.1, -0.30)   # where a fetched object goes (world x, y; before the person)
    # PHMMs (Humanoids 2008 §III) trained on the demonstrations' kinematics, 3 x 3 grid over the objects' area
    n_states: int = 6
    train_repetitions: int = 4           # movements per grid corner and class
    phmm_iter: int = 15
    noise_sigmas_m: tuple[float, ...] = (0.04, 0.08, 0.12)   # validation: observation noise added to the PHMMs
    # durations in seconds, turned into frames at the video's frame rate (`online_window`, ...)
    online_window_s: float = 0.3         # BMVC §5.4: detector look-ahead = report latency
    online_thresholds_m: tuple[float, ...] = (0.06, 0.10)  # validation: displacement over the window that starts one
    median_s: float = 0.3                # spike filter on the tracked positions (0: none)
    merge_gap_s: float = 1.0             # detected movements closer than this are one (a pointing hold, a put-down)
    # grasp recognition (GRASP §III, `grasp_stage`): eq. 3's exact kNN over HOG of the hand crop, the database
    # the grasp study's rendered views ("study": its preset `grasp_preset`, degraded to `grasp_db_pixels` when
    # set) or crops of `grasp_train_demos` transfer demonstrations of their own seed ("demonstrations")
    grasp_database: str = "demonstrations"
    grasp_preset: str = "quick"
    grasp_db_pixels: int = 0
    grasp_train_demos: int = 1000
    grasp_frames_s: tuple[float, ...] = (-0.24, -0.16, -0.08, 0.0, 0.08)   # crops around each pick-up
    grasp_window_frac: float = 0.1       # validation: skin within this fraction of the width of the hand (0: all)
    # the hand cropped from a foveal camera (`fovea`) of fovea_px x fovea_px pixels over fovea_fov_deg, turned to
    # the tracked hand at the grasp moment (0: from the left view; the window above then does not apply)
    fovea_px: int = 128
    fovea_fov_deg: float = 12.0
    # the class from the "demonstrations" crops: eq. 3's kNN ("knn") or a convnet trained on them
    # (`lfd_jax.grasp.fit_convnet`, grasp_cnn_epochs passes): on the masked hand crops ("cnn") or on the unmasked
    # boxes around the hand ("scene_cnn", the grasp study's best preset's input). Validation (quick preset, 1000
    # training demos, 150 transfers of a seed of their own, 4 crops each around the pick-up aimed at the rendered
    # hand): LDA kNN 0.41 per crop; "cnn" after 20 / 40 / 60 epochs 0.52 / 0.57 / 0.59; "scene_cnn" (40) 0.52; "cnn"
    # (40) on 2000 training demos 0.67, but in the loop (72 validation demonstrations with the robot) 20 of 36
    # grasps and 54 tasks, as with 1000, for 5 more minutes of a cold `make demo`. Both presets take "cnn" at 40
    # epochs on 1000 demos (60 epochs trained in 430 s against 250 s, two cores shared, for two points)
    grasp_classifier: str = "cnn"
    grasp_cnn_epochs: int = 40
    # the kNN's distance on the "demonstrations" crops: HOG's ("none", the paper's) or after a whitened LDA fitted on
    # them ("lda", `hog_jax.fit_metric`, covariance shrinkage grasp_lda_shrinkage). Validation (quick preset, fovea,
    # one crop per transfer at its pick-up, aimed at the hand): 48 train demos with HOG's distance 13 of 72 right;
    # 300 / 1000 / 2000 demos (crops at -1..+2 frames) HOG 27 / 33 / 30, LDA 33 / 37 / 38; 1000 demos at the
    # preset's -2..+1 frames with LDA 44 of 72, and 75 of 144 other transfers (48 demos, HOG: 34 of 144)
    grasp_metric: str = "lda"
    grasp_lda_shrinkage: float = 0.5
    # robot (sim.task_controller)
    robot: bool = True
    # the Karlsruhe hand (`python -m experiments.imitation.hand_choice`): both hands finish the tasks of each
    # class's own object alike (10 of 12), but with a class that is not the object's (a misrecognised grasp) the
    # Karlsruhe hand finished 37 of 60 and the Barrett hand 20 (MAP Fig. 2 maps Abducted Thumb to its Two-finger
    # Thumb, which lifted none of the six objects); validation demonstrations: task success 6 of 12 against 4
    robot_hand: str = "karlsruhe"
    # the robot hand's turn about the vertical: the grasp's canonical one, or the person's as eq. 4 recognised it
    # ("recognised", with the study's database only; `lfd_jax.imitation.hand_rotation`); on 5 validation transfers
    # (quick preset, study database) the recognised one finished 1 task, the canonical one 2
    robot_orientation: str = "canonical"
    approach: str = "phmm"               # the arm's approach: the synthesised reach ("phmm") or a straight line
    place_tolerance_m: float = 0.05      # a task succeeds with the right object within this of the place, upright
    # a transfer's place from the object's own displacement in the video (`lfd_jax.imitation.scene_place`; else,
    # and where that finds nothing, from the hand's), the scene at rest over place_rest_s before and after the movement
    place_from_scene: bool = True
    place_rest_s: float = 0.5

    def __post_init__(self):
        if self.video_preset not in video.PRESETS:
            raise ValueError(f"video_preset: expected one of {sorted(video.PRESETS)}, got {self.video_preset!r}")
        for name, low in (("n_persons", 2), ("n_skin_persons", 1), ("n_demos", 1), ("n_videos", 1),
                          ("n_validation", 1), ("pad_frames", 1), ("n_states", 2), ("train_repetitions", 1),
                          ("phmm_iter", 1), ("min_blob_px_160", 1), ("grasp_db_pixels", 0), ("grasp_train_demos", 1),
                          ("fovea_px", 0), ("grasp_cnn_epochs", 1)):
            check_int(getattr(self, name), name, min_value=low)
        if self.n_skin_persons >= self.n_persons:
            raise ValueError(f"n_skin_persons: must leave demonstrators among the {self.n_persons} persons")
        for name in ("online_window_s", "median_s", "merge_gap_s", "place_rest_s"):
            check_real(getattr(self, name), name, min_value=0.0, max_value=10.0)
        for name in ("noise_sigmas_m", "online_thresholds_m"):
            values = getattr(self, name)
            if not isinstance(values, tuple) or not values:
                raise ValueError(f"{name}: expected a non-empty tuple, got {values!r}")
            for v in values:
                check_real(v, name, min_value=0.0, exclusive_min=name == "online_thresholds_m")
        if not isinstance(self.handover_xy, tuple) or len(self.handover_xy) != 2:
            raise ValueError(f"handover_xy: expected (x, y), got {self.handover_xy!r}")
        check_real(self.place_tolerance_m, "place_tolerance_m", min_value=0.0, exclusive_min=True)
        if self.grasp_database not in ("study", "demonstrations"):
            raise ValueError(f"grasp_database: expected 'study' or 'demonstrations', got {self.grasp_database!r}")
        check_real(self.grasp_window_frac, "grasp_window_frac", min_value=0.0, max_value=1.0)
        if self.fovea_px and not 8 <= self.fovea_px <= 1024:
            raise ValueError(f"fovea_px: expected 0 or 8 to 1024, got {self.fovea_px}")
        check_real(self.fovea_fov_deg, "fovea_fov_deg", min_value=0.0, max_value=89.0, exclusive_min=True)
        if self.grasp_classifier not in ("knn", "cnn", "scene_cnn"):
            raise ValueError(f"grasp_classifier: expected 'knn', 'cnn' or 'scene_cnn', got {self.grasp_classifier!r}")
        if self.grasp_classifier != "knn" and self.grasp_database != "demonstrations":
            raise ValueError(f"grasp_classifier: {self.grasp_classifier!r} is trained on the 'demonstrations' crops "
                             "(grasp_database)")
        if self.grasp_metric not in ("none", "lda"):
            raise ValueError(f"grasp_metric: expected 'none' or 'lda', got {self.grasp_metric!r}")
        if self.grasp_metric == "lda" and self.grasp_database != "demonstrations":
            raise ValueError("grasp_metric: 'lda' is fitted on the 'demonstrations' crops (grasp_database)")
        check_real(self.grasp_lda_shrinkage, "grasp_lda_shrinkage", min_value=0.0, max_value=1.0)
        if not isinstance(self.grasp_frames_s, tuple) or not self.grasp_frames_s:
            raise ValueError(f"grasp_frames_s: expected a non-empty tuple, got {self.grasp_frames_s!r}")
        for v in self.grasp_frames_s:
            check_real(v, "grasp_frames_s", min_value=-10.0, max_value=10.0)
        if self.robot_hand not in ("barrett", "karlsruhe"):
            raise ValueError(f"robot_hand: expected 'barrett' or 'karlsruhe', got {self.robot_hand!r}")
        if self.robot_orientation not in ("canonical", "recognised"):
            raise ValueError(f"robot_orientation: expected 'canonical' or 'recognised', got {self.robot_orientation!r}")
        if self.approach not in ("phmm", "straight"):
            raise ValueError(f"approach: expected 'phmm' or 'straight', got {self.approach!r}")
        for name in ("robot", "coarse_scale", "place_from_scene"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name}: expected a bool, got {getattr(self, name)!r}")

    def video_settings(self) -> video.VideoSettings:
        return video.preset(self.video_preset, seed=self.seed, n_persons=self.n_persons)

    def _frames(self, seconds: float) -> int:
        return max(1, round(seconds * self.video_settings().fps))

    @property
    def online_window(self) -> int:
        """`online_window_s` in frames (at least 1)."""
        return self._frames(self.online_window_s)

    @property
    def median_frames(self) -> int:
        """`median_s` in frames, odd (1: no filter)."""
        return self._frames(self.median_s) | 1

    @property
    def merge_gap(self) -> int:
        """`merge_gap_s` in frames."""
        return self._frames(self.merge_gap_s)

    @property
    def demonstrators(self) -> int:
        """Persons 0 .. demonstrators - 1 demonstrate; the others' clips train the skin models."""
        return self.n_persons - self.n_skin_persons


VALIDATION_SEED = 1000

PRESETS = {
    "quick": {"video_preset": "quick", "n_demos": 4, "n_videos": 1, "n_validation": 2, "train_repetitions": 3,
              "phmm_iter": 10, "noise_sigmas_m": (0.05, 0.1), "online_thresholds_m": (0.08,)},
    "paper": {},
}
