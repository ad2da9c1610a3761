"""Learning from an unsegmented demonstration (LfD 2009 §III-B, §III-D, §V).

    python -m experiments.lfd_demonstration --preset quick|paper --out DIR

Long rendered recordings (`experiments.data.video.long_scripts`) through the video front end
(`hog_jax.video.front_end`: masks and the tracked hand in both views); the object in the hand from
gradient-phase differences (`hog_jax.video.segment_objects`, eqs. 1-4, Fig. 3) beside an OpenCV peer
(StereoSGBM + DIS optical flow, `experiments.peers.object_peer`); the per-frame "object in hand"
filtered over time into pick-up / put-down events (`hog_jax.video.periods_in_hand`, Fig. 8) and matched to
the ground truth.

Outputs: metrics.json, report.md, fig3_likelihood_ratios.png, fig8_object_in_hand.png.
"""
from experiments.lfd_demonstration.config import PRESETS, Config
from experiments.lfd_demonstration.stages import main

__all__ = ["PRESETS", "Config", "main"]
