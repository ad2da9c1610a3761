"""The four classifiers of the study behind one interface, and the choice of HMM settings on
validation folds inside the training persons.

Every method is `fit(X (B, S, D), y (B,), setting, cfg) -> model` and `predict(model, X) -> (B,)`
labels. The three HMM methods train one model per action and label a sequence by the highest
log-likelihood; their setting is (number of states, covariance type), chosen by `select_setting`:

* `edhmm`: `phmm_jax.fit_hmm` with explicit durations, every state lasting between
  (1 - spread) S / N and (1 + spread) S / N frames (S frames per resampled trial, N states);
* `hmm`: `phmm_jax.fit_hmm`, the classical left-right HMM (self-loops, at least one frame a state);
* `hmmlearn`: `hmmlearn.hmm.GaussianHMM` with the same left-right topology (a banded initial
  transition matrix, whose zeros EM keeps), the same start (Gaussians of an equal segmentation in
  time, `phmm_jax.em.initial_hmm`'s), the same iterations and stopping tolerance, and the same
  covariance floor added after every M step (`FlooredGaussianHMM`: hmmlearn's own `min_covar` only
  enters its k-means initialisation, and its `covars_prior` shrinks with the state's occupancy);
  unlike phmm_jax's, its paths need not end in the last state;
* `dtw`: `tslearn`'s 1-nearest-neighbour classifier under DTW (no setting to choose).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

import phmm_jax as P

N_ACTIONS = 4


class Setting(NamedTuple):
    n_states: int
    covariance: str

    def __str__(self) -> str:
        return f"{self.n_states} states, {self.covariance}"


def standardise(X_train: np.ndarray, *others: np.ndarray) -> list[np.ndarray]:
    """Every array z-scored per feature with the mean and standard deviation of X_train's frames
    (a constant feature keeps scale 1)."""
    frames = X_train.reshape(-1, X_train.shape[-1])
    mean, sd = frames.mean(0), frames.std(0)
    sd = np.where(sd > 1e-12, sd, 1.0)
    return [(X - mean) / sd for X in (X_train, *others)]


def ed_config(setting: Setting, n_frames: int, spread: float) -> P.HMMConfig:
    """The explicit-duration structure of `setting` for trials of `n_frames` frames."""
    per_state = n_frames / setting.n_states
    low = max(1, math.floor((1 - spread) * per_state))
    return P.HMMConfig(setting.n_states, low, max(low, math.ceil((1 + spread) * per_state)), setting.covariance)


def _fit_phmm_jax(X, y, config: P.HMMConfig, cfg):
    options = P.FitOptions(max_iter=cfg.n_iter, reg_covar=cfg.reg_covar)
    return [P.fit_hmm(X[y == a], config=config, options=options) for a in range(N_ACTIONS)]


def fit_edhmm(X, y, setting: Setting, cfg):
    return _fit_phmm_jax(X, y, ed_config(setting, X.shape[1], cfg.duration_spread), cfg)


def fit_hmm(X, y, setting: Setting, cfg):
    return _fit_phmm_jax(X, y, P.HMMConfig(setting.n_states, 1, None, setting.covariance), cfg)


def predict_phmm_jax(models, X):
    return np.argmax(np.stack([np.asarray(P.log_likelihood(m, X)) for m in models], axis=1), axis=1)


def floored_gaussian_hmm(reg_covar: float, **kwargs):
    """A `hmmlearn.hmm.GaussianHMM` whose M step adds `reg_covar` to every covariance diagonal, as
    `phmm_jax.FitOptions.reg_covar` does."""
    from hmmlearn.hmm import GaussianHMM

    class FlooredGaussianHMM(GaussianHMM):
        def _do_mstep(self, stats):
            super()._do_mstep(stats)
            if "c" in self.params:
                if self.covariance_type == "diag":
                    self._covars_ = self._covars_ + reg_covar
                else:
                    self._covars_ = self._covars_ + reg_covar * np.eye(self.n_features)

    return FlooredGaussianHMM(**kwargs)


def _left_right_hmmlearn(Xa: np.ndarray, setting: Setting, cfg):
    n, (_, length, dim) = setting.n_states, Xa.shape
    # phmm_jax's stopping rule (FitOptions.tol per frame of the mean log-likelihood) in hmmlearn's
    # units (the total log-likelihood)
    tol = P.FitOptions().tol * Xa.shape[0] * length
    model = floored_gaussian_hmm(cfg.reg_covar, n_components=n, covariance_type=setting.covariance, n_iter=cfg.n_iter,
                                 tol=tol, init_params="", params="stmc", random_state=cfg.seed)
    stay = max(1.0 - n / length, 1e-3)
    transmat = np.diag(np.full(n, stay)) + np.diag(np.full(n - 1, 1.0 - stay), 1)
    transmat[-1, -1] = 1.0
    model.startprob_, model.transmat_ = np.eye(n)[0], transmat
    segment = np.minimum(np.arange(length) * n // length, n - 1)  # equal segmentation in time
    frames = [Xa[:, segment == k].reshape(-1, dim) for k in range(n)]
    model.means_ = np.stack([f.mean(0) for f in frames])
    if setting.covariance == "diag":
        model.covars_ = np.stack([f.var(0) + cfg.reg_covar for f in frames])
    else:
        model.covars_ = np.stack([np.cov(f.T, bias=True) + cfg.reg_covar * np.eye(dim) for f in frames])
    model.fit(Xa.reshape(-1, dim), [length] * len(Xa))
    return model


def _blas_single_thread():
    """hmmlearn's BLAS calls on one thread: beside JAX's pool on 2 cores, threaded BLAS ran a
    full-covariance fit about 4x slower (measured while writing this study)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(1)


def fit_hmmlearn(X, y, setting: Setting, cfg):
    import logging

    logging.getLogger("hmmlearn").setLevel(logging.ERROR)  # per-iteration convergence chatter
    with _blas_single_thread():
        return [_left_right_hmmlearn(X[y == a], setting, cfg) for a in range(N_ACTIONS)]


def _score(model, x) -> float:
    try:
        return float(model.score(x))
    except ValueError:  # a model EM left with NaN parameters explains nothing
        return -np.inf


def predict_hmmlearn(models, X):
    with _blas_single_thread():
        return np.argmax(np.array([[_score(m, x) for m in models] for x in X]), axis=1)


def fit_dtw(X, y, setting, cfg):
    from tslearn.neighbors import KNeighborsTimeSeriesClassifier

    return KNeighborsTimeSeriesClassifier(n_neighbors=1, metric="dtw").fit(X, y)


def predict_dtw(model, X):
    return np.asarray(model.predict(X))


FIT = {"edhmm": fit_edhmm, "hmm": fit_hmm, "hmmlearn": fit_hmmlearn, "dtw": fit_dtw}
PREDICT = {"edhmm": predict_phmm_jax, "hmm": predict_phmm_jax, "hmmlearn": predict_hmmlearn, "dtw": predict_dtw}


def settings_grid(method: str, cfg) -> list[Setting | None]:
    if method == "dtw":
        return [None]
    return [Setting(n, c) for n in cfg.grid_states for c in cfg.grid_covariance]


def select_setting(method: str, X, y, persons, cfg, rng: np.random.Generator):
    """The setting of `method` with the best mean accuracy over `cfg.n_validation_folds` inner
    leave-one-person-out folds of the training data only (validation persons drawn by `rng`; ties go
    to the earlier, smaller setting). Returns (setting, {str(setting): mean validation accuracy})."""
    grid = settings_grid(method, cfg)
    unique = sorted(set(persons.tolist()))
    if len(grid) == 1 or len(unique) < 2:
        return grid[0], {}
    held = rng.permutation(unique)[:cfg.n_validation_folds]
    scores = {}
    for setting in grid:
        accs = []
        for person in held:
            inner_train, inner_val = standardise(X[persons != person], X[persons == person])
            model = FIT[method](inner_train, y[persons != person], setting, cfg)
            accs.append(np.mean(PREDICT[method](model, inner_val) == y[persons == person]))
        scores[str(setting)] = float(np.mean(accs))
    best = max(range(len(grid)), key=lambda k: (scores[str(grid[k])], -k))
    return grid[best], scores
