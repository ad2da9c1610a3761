"""PHMM table-top study (Humanoids 2008 §IV-V, BMVC 2008 §5) on simulated motion capture.

    python -m experiments.phmm_tabletop --preset quick|paper --out DIR

Protocol: PHMMs (20 states, 4-6 steps per state, sequences resampled to 100 samples) of reaching and
pointing trained on a 3 x 3 raster (and on its 4 outer corners, 2 x 2) of the 80 x 30 cm table area;
tested on a 5 x 7 raster. Measured:
* synthesis error (eq. 25): RMS over the 7 markers between the synthesised movement and the average
  of the test repetitions (an 80-state HMM re-synthesis), after DTW, first and last 10 % excluded;
* parameter recognition: the table position interpolated from phi* (eq. 3), error in cm; the
  log-likelihood surface over (u, v) for one movement;
* classification pointing vs reaching: PHMM 2 x 2, 3 x 3, classical left-right HMMs (one per
  action, all positions), and a diagnostic-feature logistic regression;
* robustness to i.i.d. Gaussian noise on every sample;
* robot: synthesised reaching movements retargeted to a HOAP-3-like arm (eqs. 10-24) and played back
  in MuJoCo: grasp-point error, elbow-in-plane check, clearance to the table.
"""
from experiments.phmm_tabletop.config import PAPER, PRESETS, Config
from experiments.phmm_tabletop.demo import demo_stage
from experiments.phmm_tabletop.measures import (RobotSetup, diagnostic_baseline, diagnostic_features, dtw_rms,
                                                final_markers, hand_centre, inner_mask, local_maxima, loglik_surface,
                                                phi_to_position, regression_baseline, robot_metrics, synthesis_error)
from experiments.phmm_tabletop.stages import main

__all__ = ["PAPER", "PRESETS", "Config", "RobotSetup", "demo_stage", "diagnostic_baseline", "diagnostic_features",
           "dtw_rms", "final_markers", "hand_centre", "inner_mask", "local_maxima", "loglik_surface", "main", "phi_to_position",
           "regression_baseline", "robot_metrics", "synthesis_error"]
