"""crf_jax: the CRF family of Kjellström et al. (ECCV 2008 §3-4; LfD 2009 §IV) in JAX, trained with optax.

Shapes: B sequences, T (padded) frames, D features per frame, K labels, H hidden states per class,
Ka / Ko action / object labels, C connectivity (each label sees x_{t-C..t+C}). Batches are padded
arrays X (B, T, D) plus lengths (B,) (None = all T); padding never reaches values or gradients.
Everything is in log space, every function that takes user data raises `ValueError` naming the
argument, and every public function returns jax arrays (batch-first; several results are
NamedTuples).

- Linear-chain CRF (eqs. 3-4): `fit_chain`, `predict`, `predict_marginals`, `segment_log_probs`,
  `log_likelihood`.
- Hidden CRF (eqs. 5-6): `fit_hcrf`, `hcrf_log_probs`, `hcrf_predict`.
- Factorial CRF (eq. 7): `fit_fcrf`, `fcrf_marginals`, `fcrf_segment_log_probs`,
  `fcrf_predict_segments`.
- Late fusion (eq. 8, LfD eq. 9) and the object-history prior (LfD eq. 10): `cooccurrence`, `fuse`,
  `history_prior`, `apply_history`.
- Per-vector baselines: `fit_linear`, `linear_predict`, `linear_log_proba`.
- Fitting: every `fit_*` takes the data, the model-defining arguments, `l2` (part of the objective,
  CRFsuite's c2) and `options=FitOptions(...)` (how to search), and returns
  `FitResult(model, info: TrainInfo)`; `minimize` is the shared solver. Persistence: `save`, `load`.

Example:
    ```python
    import crf_jax

    model, info = crf_jax.fit_chain(X, y, lengths, l2=1.0,            # X (B, T, D), y (B, T)
                                    options=crf_jax.FitOptions(max_iter=100))
    labels = crf_jax.predict(model, X_test, lengths_test)           # (B', T)
    la = crf_jax.segment_log_probs(action_model, Xa, la_len)        # (B', Ka)
    lo = crf_jax.segment_log_probs(object_model, Xo, lo_len)        # (B', Ko)
    fused = crf_jax.fuse(la, lo, crf_jax.cooccurrence(a_tr, o_tr, Ka, Ko, smoothing=0.1))
    crf_jax.save("chain.npz", model); model = crf_jax.load("chain.npz")
    ```
"""
from crf_jax._src.chain import (ChainCRF, ChainStructure, init_chain, log_likelihood, predict,
                                predict_marginals, segment_log_probs)
from crf_jax._src.chcrf import CHCRFResult, HistoryPosterior, apply_history, cooccurrence, fuse, history_prior
from crf_jax._src.fcrf import (FCRF, FCRFMarginals, FCRFStructure, SegmentLabels,
                               predict_marginals as fcrf_marginals, predict_segments as fcrf_predict_segments,
                               segment_log_probs as fcrf_segment_log_probs, init_fcrf)
from crf_jax._src.hcrf import (HCRF, HCRFStructure, log_probs as hcrf_log_probs, predict as hcrf_predict,
                               init_hcrf)
from crf_jax._src.io import load, save
from crf_jax._src.linear import (LinearModel, LinearStructure, init_linear,
                                 predict_log_proba as linear_log_proba, predict as linear_predict)
from crf_jax._src.solver import FitOptions, FitResult, TrainInfo, minimize
from crf_jax._src.train import fit_chain, fit_fcrf, fit_hcrf, fit_linear
from lfd_common import pad_sequences

__all__ = [
    "CHCRFResult", "ChainCRF", "ChainStructure", "FCRF", "FCRFMarginals", "FCRFStructure", "FitOptions", "FitResult",
    "HCRF", "HCRFStructure", "HistoryPosterior", "LinearModel", "LinearStructure", "SegmentLabels", "TrainInfo", "apply_history",
    "cooccurrence", "fcrf_marginals", "fcrf_predict_segments", "fcrf_segment_log_probs", "fit_chain", "fit_fcrf", "fit_hcrf", "fit_linear",
    "fuse", "hcrf_log_probs", "hcrf_predict", "history_prior", "init_chain", "init_fcrf", "init_hcrf", "init_linear",
    "linear_log_proba", "linear_predict", "load", "log_likelihood", "minimize", "pad_sequences", "predict", "predict_marginals",
    "save", "segment_log_probs",
]
