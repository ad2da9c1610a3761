"""crf_jax: the CRF family of Kjellström et al. (ECCV 2008 §3-4; LfD 2009 §IV) in JAX, trained with optax.

Shapes: B sequences, T (padded) frames, D features per frame, K labels, H hidden states per class,
Ka / Ko action / object labels, C connectivity (each label sees x_{t-C..t+C}), W = 2C + 1.
Batches are padded arrays X (B, T, D) plus lengths (B,) (None = all T); padding never reaches
values or gradients. Everything that takes user data validates it (ValueError naming the argument).
Everything is in log space.

Fitting: every fit_* takes the data, the model-defining arguments (label counts, connectivity,
hidden states, inference), l2 (part of the objective: sum NLL + l2 ||theta||^2, CRFsuite's c2
convention), validation data for early stopping, and options=FitOptions(...) (how to search:
method "lbfgs" | "adam" or any optax optimizer, max_iter, memory_size, learning_rate, gtol, delta,
period, patience, eval_every; all but the optimiser, max_iter and memory_size are traced, so
changing them never recompiles). It
returns FitResult(model, info: TrainInfo). Options are never stored in a model. A non-finite
objective is never reported as converged: at the start it is a ValueError naming X (features too large
for float32), later the last finite parameters come back with info.diverged set and a RuntimeWarning.

Linear-chain CRF (eqs. 3-4)
    fit_chain(X, y, lengths, n_labels=, connectivity=0, l2=1.0, validation=(Xv, yv[, lv]),
              options=FitOptions(), mesh=None)      -> FitResult(ChainCRF, TrainInfo)   y (B, T)
                                                       mesh: data-parallel over a jax.sharding.Mesh
    predict(model, X, lengths)                       -> (B, T) Viterbi labels, -1 on padding
    predict_marginals(model, X, lengths)             -> (B, T, K) P(y_t = k | x), each real row sums to 1
    segment_log_probs(model, X, lengths)             -> (B, K) log P(y_t = k for all t | x)  (pre-segmented, §4)
    log_likelihood(model, X, y, lengths)             -> (B,) log P(y | x)
Hidden CRF (eqs. 5-6)
    fit_hcrf(X, y, lengths, n_hidden=3, ...)         -> FitResult(HCRF, TrainInfo)       y (B,)
    hcrf_log_probs(model, X, lengths) -> (B, K);  hcrf_predict -> (B,)
Factorial CRF, two coupled chains (eq. 7)
    fit_fcrf(X, y_action, y_object, lengths, inference="exact"|"loopy")  -> FitResult(FCRF, TrainInfo)
    fcrf_marginals(model, X, lengths, method="exact"|"loopy")  -> FCRFMarginals(action (B, T, Ka), object (B, T, Ko))
    fcrf_segment_log_probs(...) -> (B, Ka, Ko);  fcrf_predict_segments(...) -> SegmentLabels(action (B,), object (B,))
CHCRF late fusion (eq. 8 / LfD eq. 9) and object history (LfD eq. 10)
    cooccurrence(actions, objects, Ka, Ko, smoothing=0.0)  -> K (Ka, Ko)  (no pairs: needs smoothing > 0)
    fuse(log_p_action (B, Ka), log_p_object (B, Ko), K)    -> CHCRFResult(log_joint (B, Ka, Ko),
                                                               log_z (B,), log_action, log_object,
                                                               impossible (B,): Z = 0, all -inf, never NaN)
    history_prior(history (I, Ka, Ko), history_positions (I, P), position (P,), default_distance) -> (Ka, Ko)
    apply_history(log_joint (Ka, Ko), prior (Ka, Ko))     -> HistoryPosterior(log_joint, log_normaliser)
Baselines
    fit_linear(X (N, D), y (N,), kind="logistic"|"svm", options=FitOptions.for_linear(kind))
                                                     -> FitResult(LinearModel, TrainInfo)
    linear_predict(model, X) -> (N,);  linear_log_proba(model, X) -> (N, K)
Persistence (lfd_common's model files: kind + structure JSON + arrays, checked on load)
    save(path, model); load(path) -> the stored ChainCRF | HCRF | FCRF | LinearModel
    model.structure -> ChainStructure | HCRFStructure | FCRFStructure | LinearStructure (what defines it)
Low level (pure JAX, one sequence or leading batch axes, no validation)
    crf_jax.inference.log_partition / forward_backward / marginals / viterbi(unary (T, K), trans (K, K), length)
    crf_jax.fcrf.loopy_bp, crf_jax.minimize(objective, params, data, val_data, options)

Every public function returns jax arrays (batch-first); several results are NamedTuples.

Example::

    import crf_jax
    model, info = crf_jax.fit_chain(X, y, lengths, l2=1.0,            # X (B, T, D), y (B, T)
                                    options=crf_jax.FitOptions(max_iter=100))
    labels = crf_jax.predict(model, X_test, lengths_test)           # (B', T)
    la = crf_jax.segment_log_probs(action_model, Xa, la_len)        # (B', Ka)
    lo = crf_jax.segment_log_probs(object_model, Xo, lo_len)        # (B', Ko)
    fused = crf_jax.fuse(la, lo, crf_jax.cooccurrence(a_tr, o_tr, Ka, Ko, smoothing=0.1))
    crf_jax.save("chain.npz", model); model = crf_jax.load("chain.npz")
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
