"""Grasp recognition from one image (GRASP: Kjellström, Romero & Kragic, IROS 2008, §III-B, §V, §VII).

    python -m experiments.grasp_recognition --preset quick|paper|best --out DIR
    python -m experiments.grasp_recognition.ablation --split validation|test --out DIR

Database: the MuJoCo human hand (`sim.human_hand`, DEFAULT_SHAPE) in the six reference grasps
(`sim.human_grasps`) holding black objects, rendered from an azimuth x elevation grid over the upper
half-sphere (paper: 60 x 15 = 900 views per grasp, 6-degree steps), cropped and centred, HOG pyramid
(B = 4, L = 3) -> hyperplane LSH (tuned on held-out database-like views to recall@k >= 0.9) ->
distance-weighted kNN (eq. 3 class, eq. 4 orientation).

Tests (`experiments.data.grasp_tests`): a different hand (TEST_SHAPE) with perturbed postures, other
lighting, clutter, noise and blur; X (36 reach-to-grasp snapshots, two off-grid viewpoints per grasp),
X' (24, without the most neutral snapshots), X'' (12 completed grasps) and a large random set. Every
test frame goes through the `hog_jax` skin segmentation (skin model fitted on hands of other skin
tones and other clutter); a frame where no skin is found counts as an error.

Presets: `paper` is the paper's method as it is; `best` (chosen on a validation split of its
own seed and hand, `ablation`) adds a domain-randomised database (`experiments.data.grasp_database`), a
whitened-LDA metric, a skin model adapted to each frame, the class from a small convnet on the unmasked
box around the hand (the held object included) trained on rendered scenes (`lfd_jax.grasp.fit_convnet`,
`grasp_database.randomized_scenes`; eq. 4's orientation within that class) and multi-probe LSH tuned on
query-like validation images. Both run the ladder (`ladder`): the test sets re-rendered with one more of their
differences from the database per rung, from the database hand on black to the full test.

Outputs: metrics.json, report.md, confusion.png (Fig. 7), orientation.png (Fig. 8), neighbours.png
(Fig. 5), sweeps.png (accuracy against k, database size, B x L; paper preset), contact_sheet.png,
ladder.png.
"""
from experiments.grasp_recognition.config import PAPER, PRESETS, Config, parse_grid
from experiments.grasp_recognition.demo import demo_stage
from experiments.grasp_recognition.pieces import confusion, orientation_errors_deg, symmetric_errors_deg, wilson_interval
from sim.grasping import GRASP_CLASSES
from experiments.grasp_recognition.stages import main, run_experiment

__all__ = ["GRASP_CLASSES", "PAPER", "PRESETS", "Config", "parse_grid", "confusion", "demo_stage", "main", "orientation_errors_deg",
           "run_experiment", "symmetric_errors_deg", "wilson_interval"]
