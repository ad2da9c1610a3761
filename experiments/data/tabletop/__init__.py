"""Simulated motion capture of table-top reaching and pointing (PHMM papers, Humanoids 2008 §V, BMVC §5).

A seated person's kinematic upper body: a trunk that leans and turns about the hip (so that far targets
can be reached, with the sternum and shoulder moving), a shoulder girdle that protracts and elevates
with the arm, a 3-DoF shoulder and 1-DoF elbow solved from the wrist path with a random elbow swivel,
a wrist whose posture varies, and a hand with index finger and thumb. Seven markers, in the papers'
order (`MARKERS`): sternum, shoulder, elbow, wrist, index knuckle, index tip, thumb tip; 60 Hz; metres.

Frame: x to the subject's right, y forward (away from the body), z up; origin on the floor below the
middle of the hips. The 80 x 30 cm target raster lies on the table in front of the subject.

Actions (both start and end with the arm hanging beside the hip):
* reaching: the hand centre goes to the object on the table (grasp posture: fingers flexed around it,
  forearm pronated by a random amount), holds (grasp), withdraws;
* pointing: the arm extends and the index finger points at the target along the eye-finger line,
  from a distance that depends on the person's habitual arm extension; holds, withdraws.
The hand rises before it moves out over the table edge (and goes back before it drops), along a
minimum-jerk profile with random duration, peak-velocity asymmetry and hold time.

Variability: per-subject anthropometry (stature 1.55-1.95 m, segment proportions +-3 %) and style
(pointing extension, elbow swivel, speed); per repetition: timing (+-20 % overall), asymmetry, hold,
end-point scatter (`endpoint_sd_m`), wrist posture, swivel, object height; marker noise
(`marker_noise_m`); occasionally dropped marker frames, filled by linear interpolation (`fill_gaps`,
which the loader of real recordings uses too).

In-memory format (`Recordings`, also produced by `load_recording` from `.npz` / `.csv` files):
markers (B, T, M, 3) padded by repeating the last frame, lengths (B,), action (B,) index into
`ACTIONS`, target (B, 3), frame_rate (Hz), marker_names (M,).
"""
from __future__ import annotations

from experiments.data.tabletop.subjects import (ACTIONS, FRAME_RATE_HZ, MARKERS, RASTER_ORIGIN, RASTER_SIZE_M,
                                                Recordings, Subject, TABLE_EDGE_Y, TABLE_HEIGHT_M, raster_targets,
                                                sample_subject)
from experiments.data.tabletop.movement import fill_gaps, simulate_movement
from experiments.data.tabletop.recordings import (concatenate, protocol_data, resample, simulate, stack_recordings,
                                                  table_penetration)
from experiments.data.tabletop.files import load_recording, save_recording

__all__ = ["ACTIONS", "FRAME_RATE_HZ", "MARKERS", "RASTER_ORIGIN", "RASTER_SIZE_M", "Recordings", "Subject",
           "TABLE_EDGE_Y", "TABLE_HEIGHT_M", "concatenate", "fill_gaps", "load_recording", "protocol_data",
           "raster_targets", "resample", "sample_subject", "save_recording", "simulate", "simulate_movement",
           "stack_recordings", "table_penetration"]
