"""MAP §IV-A in MuJoCo: human grasp -> robot grasp on two hands, under object pose errors, as one batch.

    python -m experiments.grasp_mapping --preset quick|paper --out DIR [--backend auto|native|mjx-jax|mjx-warp]

For each hand (Barrett-like, Karlsruhe-like) and human grasp class, the robot preshape and hand pose are
taken from the human reference grasp (`sim.human_grasps`), and the grasp is executed (approach, tactile
correction for volar grasps, close, lift 10 cm, hold 1 s) under the paper's conditions: no error; the
object 5 cm off in 6 directions (multiples of pi/3); the object's orientation estimate off by 15 and 30
degrees; volar grasps each with and without tactile correction (non-volar grasps are open-loop in
both, so they run once); `n_seeds` seeds of hand-pose noise per condition. Contacts at the end of
closing give virtual fingers, matched to the human grasp's (`sim.virtual_fingers`).

Writes metrics.json (flat keys; the per hand x grasp x condition tables `success_rate_by_condition`,
`vf_position_error_mm`, `vf_orientation_error_deg`, `no_contact_rate`, `tactile_gain_mm` flattened,
e.g. `vf_position_error_mm_barrett_<grasp>_<condition>`), report.md (the paper's four claims checked),
fig4.png (errors per grasp and condition, both hands), success.png, frames.png and one
frame_<hand>_<grasp>.png per hand and grasp (the no-error trial, at the end of the hold).
"""
from experiments.grasp_mapping.config import PRESETS, Condition, Config, conditions, trial_table
from experiments.grasp_mapping.demo import grasp_demo_stage
from experiments.grasp_mapping.stages import main
from experiments.grasp_mapping.trials import claims, kind_mean, run_hand, summarise

__all__ = ["PRESETS", "Condition", "Config", "claims", "conditions", "grasp_demo_stage", "kind_mean", "main",
           "run_hand", "summarise", "trial_table"]
