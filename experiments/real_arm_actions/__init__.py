"""Real arm actions: the four UE-ADL daily-living actions (forward reach, reach across,
drink, comb hair) recognised on held-out persons from real motion capture.

    python -m experiments.real_arm_actions --data ../shared/data/ue_adl --preset quick|paper --out DIR
    python -m experiments.real_arm_actions --train DIR --test DIR

Reads any folder laid out like UE-ADL (`experiments.data.ue_adl`): joint-angle files of every person
and, where there is a `markers/` folder, the raw Vicon trajectories. Explicit-duration and classical
HMMs of `phmm_jax` (one per action) beside hmmlearn's GaussianHMM and tslearn's 1-NN DTW on the same
folds, HMM settings chosen on validation folds inside the training persons; 1-D PHMMs over the reach
side (left/right arm), the one parameter the recordings have. Skips with a message when the folder
is absent.
"""
from experiments.real_arm_actions.config import METHODS, PRESETS, Config
from experiments.real_arm_actions.stages import main

__all__ = ["METHODS", "PRESETS", "Config", "main"]
