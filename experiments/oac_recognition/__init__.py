"""Simultaneous recognition of manipulation actions and manipulated objects on simulated OAC data
(ECCV 2008 §5, Tables 2-4; LfD 2009 §V, Table I).

    python -m experiments.oac_recognition --preset quick|paper --out DIR

Protocol. The papers' error cells are all multiples of 1/150 (5.3 % = 8/150, 9.3 % = 14/150, ...),
so a "run" is read here as one complete leave-one-person-out pass over the whole data set: each
person in turn is the test set, the CRFs are trained on the others, and the run's error is the
fraction of all N = 150 recordings misclassified. The 9 runs differ in which training person is
held out as the validation set for early stopping in each fold (drawn from `--seed` and the run
index) and in the HCRF's random initialisation; tables give the median (max) over the runs.

Models (crf_jax): linear-chain CRFs with connectivity C = 0, 1, 2 and an HCRF (`n_hidden` hidden
states per class) as pre-segmented classifiers P(y | x) = P(y_t = y for all t | x) (§4); baselines:
an action CRF on the 2-D hand position only, and a linear SVM on the first frame's object HOG; a
factorial CRF (exact inference in the 3 x 3 product space) on [x^a, x^o] with per-frame action and
object labels; CHCRF late fusion with the co-occurrence K of the training labels (eq. 8).
Features are standardised per dimension on each fold's training frames (so the position dimensions
have the same spread as the HOG dimensions, the papers' rule, §3). The protocol and the models live in
`experiments.data.oac_protocol`, shared with `experiments.lfd_demonstration`.

Outputs: metrics.json (flat keys, e.g. `table2_actions_crf_conn0_error_pct_median`: the tables
`table2`, `table3`, `table4`, `table_lfd` of {median, max} error %, flattened; `runtime_s`), report.md (every cell beside the paper's, the
papers' conclusions checked), trajectories.png (hand position per class, like LfD Fig. 7),
views.png (rendered hand and object views over one recording per class), errors.png.
"""
from experiments.oac_recognition.config import PRESETS, Config
from experiments.oac_recognition.demo import demo_stage
from experiments.oac_recognition.report import conclusions
from experiments.oac_recognition.stages import main

__all__ = ["PRESETS", "Config", "conclusions", "demo_stage", "main"]
