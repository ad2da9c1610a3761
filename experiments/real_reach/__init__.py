"""Real reaches: the cube's size (S / M / L) recognised from real reach-to-grasp tracks by a d = 1
PHMM beside end-pose and sequence baselines, online along the reach, and the reach's onset and
contact found online, leaving one person out.

    python -m experiments.real_reach --data ../shared/data/reach_grasp --preset quick|paper --out DIR

Reads the OpenPose tracks of the reach-grasp release (`lfd_jax.load_reach_npz`; Dagioglou et al.,
HCII 2022): per frame the wrist, the thumb, index and middle finger tips and two grip apertures, in
pixels or normalised per person (onset resting pose, shoulder width, resting hand length). Per held-out person: a PHMM whose
parameter is the size in cm (PHMM §III-B), nearest class mean on the largest grip aperture, linear
regression from the last frame, hmmlearn per size and 1-NN DTW, on 20–100 % of the reach; a
wrist-speed threshold and a fixed-lag left-right HMM for onset and contact. Every setting is
chosen on the training persons. Skips with a message when the data are absent.
"""
from experiments.real_reach.config import METHODS, PRESETS, Config
from experiments.real_reach.stages import main

__all__ = ["METHODS", "PRESETS", "Config", "main"]
