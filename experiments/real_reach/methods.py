"""The five size classifiers of the study, each able to answer on a prefix of the reach.

A reach is a (L, D) array of per-frame features; a prefix of fraction f keeps its first
max(2, round(f L)) frames. Every method is fitted on the training persons' reaches (z-scored with
their frames' mean and standard deviation) and returns a size class (index into `data.SIZES`):

* `phmm`: a d = 1 PHMM of `phmm_jax` (synchronised local training, PHMM §III-B1) whose parameter is
  the size in cm, its corners at S and L (φ = (size − 2.5) / 5) or at S, M and L (φ = 0, ½, 1, cm
  piecewise linear in φ); the recognised φ (PHMM eq. 3, `phmm_jax.recognize`) is turned into cm and
  snapped to the nearest size. On a prefix, the φ of a lattice over [−ε, 1 + ε] with the highest
  forward probability of the frames so far (paths still running).
* `phmm_cv`: the same φ, classified by the nearest class mean of the training persons'
  cross-validated φ (each training person's φ from a PHMM fitted on the other training persons):
  a discriminative calibration of φ instead of snapping it to the nearest corner.
* `phmm_person`: as `phmm_cv`, but every φ z-scored over its person's reaches (the held-out person's
  unlabelled reaches, each training person's cross-validated φ): a per-person offset and scale of φ.
* `aperture`: nearest class mean of the largest grip apertures so far (thumb–index, thumb–middle).
* `aperture_person`: the same with the largest apertures z-scored per person (the baseline given the
  per-person calibration `phmm_person` gets).
* `regression`: least squares from the last frame's features (and 1) to the size in cm, snapped.
* `hmmlearn`: one left-right `hmmlearn.hmm.GaussianHMM` per size trained on full reaches; the size
  of highest log-likelihood of the prefix (hmmlearn's paths may end in any state).
* `dtw`: 1-NN under DTW (`dtw_distances`, tslearn's definition) against the training reaches' prefixes of the same fraction.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

import phmm_jax as P
from experiments.real_reach.data import APERTURES, SIZE_CM

N_SIZES = 3


class Setting(NamedTuple):
    """States per HMM, covariance floor (standardised units squared), PHMM corners ('SL', 'SML';
    None for hmmlearn), PHMM covariances tied across the corners."""

    n_states: int
    floor: float
    grid: str | None = None
    tied: bool = False

    def __str__(self) -> str:
        return (f"{self.n_states} states, floor {self.floor:g}" + (f", corners {self.grid}" if self.grid else "")
                + (", tied" if self.tied else ""))


def prefix_length(length: int, fraction: float) -> int:
    """Frames in the prefix of `fraction` of a reach of `length` frames: round(f L), at least 2."""
    return max(2, min(length, int(round(fraction * length))))


def prefixes(seqs: list[np.ndarray], fraction: float) -> list[np.ndarray]:
    """The prefix of `fraction` of every sequence."""
    return [s[:prefix_length(len(s), fraction)] for s in seqs]


def standardise(train: list[np.ndarray], *others: list[np.ndarray]) -> list[list[np.ndarray]]:
    """Every list of sequences z-scored per feature with the training frames' mean and deviation."""
    frames = np.concatenate(train)
    mean, sd = frames.mean(0), frames.std(0)
    sd = np.where(sd > 1e-12, sd, 1.0)
    return [[(s - mean) / sd for s in seqs] for seqs in (train, *others)]


def snap(cm: np.ndarray) -> np.ndarray:
    """The size class nearest to each estimate in cm."""
    return np.argmin(np.abs(np.asarray(cm, float)[:, None] - SIZE_CM[None]), axis=1)


def corner_phi(grid: str) -> np.ndarray:
    """φ of the PHMM's corners: S, L at 0, 1 ('SL'); S, M, L at 0, ½, 1 ('SML')."""
    return np.array([0.0, 1.0]) if grid == "SL" else np.array([0.0, 0.5, 1.0])


def phi_to_cm(phi, grid: str) -> np.ndarray:
    """Size in cm of φ: linear through the corners, extrapolated outside [0, 1] by the end slopes."""
    phi = np.asarray(phi, float)
    nodes, cm = corner_phi(grid), (SIZE_CM[[0, 2]] if grid == "SL" else SIZE_CM)
    low = cm[0] + (phi - nodes[0]) * (cm[1] - cm[0]) / (nodes[1] - nodes[0])
    high = cm[-1] + (phi - nodes[-1]) * (cm[-1] - cm[-2]) / (nodes[-1] - nodes[-2])
    return np.where(phi < 0, low, np.where(phi > 1, high, np.interp(phi, nodes, cm)))


def _bucket(n: int, step: int) -> int:
    return step * -(-n // step)


def pad(seqs: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(X (B', T', D), lengths (B',)) with B' and T' rounded up to multiples of 32 and 16, so that
    folds of different sizes share JAX's compiled programs; the extra rows repeat the first sequence
    (callers keep the first B answers)."""
    lengths = np.array([len(s) for s in seqs])
    n_rows = _bucket(len(seqs), 32)
    X = np.zeros((n_rows, _bucket(lengths.max(), 16), seqs[0].shape[1]))
    for k, s in enumerate(seqs):
        X[k, :len(s)] = s
    X[len(seqs):, :lengths[0]] = seqs[0]
    return X, np.concatenate([lengths, np.full(n_rows - len(seqs), lengths[0])])


# --- PHMM ---

def fit_phmm(Z: list[np.ndarray], y: np.ndarray, setting: Setting, cfg) -> P.PHMM:
    """The d = 1 PHMM over the size: one corner per size of `setting.grid`, classical left-right
    local HMMs with diagonal covariances (synchronised local training, `phmm_jax.fit_phmm`); with
    `setting.tied`, each state's covariance replaced by its mean over the corners, so that φ moves
    the means only and a wider corner cannot win by its spread (the log-determinant term)."""
    classes = (0, 2) if setting.grid == "SL" else (0, 1, 2)
    groups = [[z for z, c in zip(Z, y) if c == k] for k in classes]
    config = P.HMMConfig(setting.n_states, 1, None, "diag")
    phmm = P.fit_phmm(groups, (len(classes),), config, options=P.FitOptions(max_iter=cfg.n_iter, reg_covar=setting.floor))
    if not setting.tied:
        return phmm
    cov = phmm.local.covariances
    tied = dataclasses.replace(phmm.local, covariances=jnp.broadcast_to(cov.mean(0, keepdims=True), cov.shape))
    return dataclasses.replace(phmm, local=tied)


def recognise_phmm(phmm: P.PHMM, Z: list[np.ndarray], cfg) -> np.ndarray:
    """φ (B,) recognised on whole reaches (`phmm_jax.recognize`)."""
    X, lengths = pad(Z)
    rec = P.recognize(phmm, X, lengths, epsilon=cfg.epsilon, n_steps=cfg.recognition_steps)
    return np.asarray(rec.phi)[:len(Z), 0, 0]


def phi_lattice(cfg) -> np.ndarray:
    """`cfg.n_phi` evenly spaced φ over [−ε, 1 + ε]."""
    return np.linspace(-cfg.epsilon, 1.0 + cfg.epsilon, cfg.n_phi)


def prefix_profile(phmm: P.PHMM, Z: list[np.ndarray], cfg) -> tuple[np.ndarray, np.ndarray]:
    """(log p(x_{0:t}, path running | φ) (G, B, T) on the φ lattice, lengths (B,)): the forward
    messages of the interpolated HMM at every lattice φ, summed over the pseudo-states."""
    X, lengths = pad(Z)
    out = []
    for phi in phi_lattice(cfg):
        alpha = np.asarray(P.messages(P.interpolate(phmm, np.array([phi])), X, lengths).log_alpha, float)
        flat = alpha.reshape(alpha.shape[0], alpha.shape[1], -1)
        top = np.max(flat, axis=-1, keepdims=True)
        top = np.where(np.isfinite(top), top, 0.0)
        with np.errstate(divide="ignore"):
            out.append(np.log(np.sum(np.exp(flat - top), axis=-1)) + top[..., 0])
    return np.stack(out)[:, :len(Z)], lengths[:len(Z)]


def profile_at(profile: np.ndarray, lengths: np.ndarray, fraction: float) -> np.ndarray:
    """(G, B) prefix log-likelihoods at the prefix of `fraction` of each reach."""
    ends = np.array([prefix_length(n, fraction) for n in lengths]) - 1
    return profile[:, np.arange(len(lengths)), ends]


def phi_by_fraction(phmm: P.PHMM, Z: list[np.ndarray], profile: np.ndarray, lengths: np.ndarray, cfg
                    ) -> dict[float, np.ndarray]:
    """{fraction: φ (B,)} for every `cfg.fractions`: on whole reaches `recognise_phmm`'s search
    (the lattice's best φ when `cfg.search` is off), on prefixes the lattice φ of the highest
    prefix likelihood (`profile`, `lengths` from `prefix_profile` of `phmm` on `Z`)."""
    lattice = phi_lattice(cfg)
    out = {f: lattice[np.argmax(profile_at(profile, lengths, f), axis=0)] for f in cfg.fractions}
    if cfg.search:
        out[1.0] = recognise_phmm(phmm, Z, cfg)
    return out


def cross_validated_phi(seqs: list[np.ndarray], y: np.ndarray, persons: np.ndarray, setting: Setting, cfg
                        ) -> dict[float, np.ndarray]:
    """{fraction: φ (B,)} of every sequence from the PHMM with `setting` fitted on the other persons'
    sequences (leave one person out, features standardised with those persons' frames)."""
    out = {f: np.zeros(len(seqs)) for f in cfg.fractions}
    for person in sorted(set(persons.tolist())):
        held = persons == person
        Z_in, Z_out = standardise([s for s, k in zip(seqs, held) if not k], [s for s, k in zip(seqs, held) if k])
        phmm = fit_phmm(Z_in, y[~held], setting, cfg)
        phi = phi_by_fraction(phmm, Z_out, *prefix_profile(phmm, Z_out, cfg), cfg)
        for f in cfg.fractions:
            out[f][held] = phi[f]
    return out


# --- hmmlearn ---

def _hmmlearn_model(Za: list[np.ndarray], setting: Setting, cfg):
    """Left-right GaussianHMM (diagonal), started from an equal segmentation in time, the covariance
    floor added after every M step as `phmm_jax.FitOptions.reg_covar` does."""
    from hmmlearn.hmm import GaussianHMM

    floor = setting.floor

    class FlooredGaussianHMM(GaussianHMM):
        def _do_mstep(self, stats):
            super()._do_mstep(stats)
            self._covars_ = self._covars_ + floor

    n = setting.n_states
    mean_length = float(np.mean([len(z) for z in Za]))
    model = FlooredGaussianHMM(n_components=n, covariance_type="diag", n_iter=cfg.n_iter, init_params="",
                               params="stmc", random_state=cfg.seed)
    stay = max(1.0 - n / mean_length, 1e-3)
    transmat = np.diag(np.full(n, stay)) + np.diag(np.full(n - 1, 1.0 - stay), 1)
    transmat[-1, -1] = 1.0
    model.startprob_, model.transmat_ = np.eye(n)[0], transmat
    segments = [np.minimum(np.arange(len(z)) * n // len(z), n - 1) for z in Za]
    frames = [np.concatenate([z[s == k] for z, s in zip(Za, segments)]) for k in range(n)]
    model.means_ = np.stack([f.mean(0) for f in frames])
    model.covars_ = np.stack([f.var(0) + floor for f in frames])
    model.fit(np.concatenate(Za), [len(z) for z in Za])
    return model


def fit_hmmlearn(Z, y, setting: Setting, cfg):
    """One left-right hmmlearn GaussianHMM per size (BLAS on one thread beside JAX's pool)."""
    import logging

    from threadpoolctl import threadpool_limits

    logging.getLogger("hmmlearn").setLevel(logging.ERROR)
    with threadpool_limits(1):
        return [_hmmlearn_model([z for z, c in zip(Z, y) if c == k], setting, cfg) for k in range(N_SIZES)]


def _score(model, z) -> float:
    try:
        return float(model.score(z))
    except ValueError:
        return -np.inf


def predict_hmmlearn(models, Z) -> np.ndarray:
    """The size whose model gives each sequence the highest log-likelihood."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        return np.argmax(np.array([[_score(m, z) for m in models] for z in Z]), axis=1)


# --- baselines fitted on the training prefixes of the same fraction ---

def max_apertures(Z: list[np.ndarray]) -> np.ndarray:
    """(B, 2) the largest thumb–index and thumb–middle apertures of each sequence."""
    return np.stack([z[:, list(APERTURES)].max(0) for z in Z])


def standardise_per_person(x: np.ndarray, persons: np.ndarray) -> np.ndarray:
    """(B, K) `x` z-scored per column over the rows of each person (`persons` (B,)): the person's
    offset and scale, read off that person's unlabelled rows."""
    out = np.empty_like(x, dtype=float)
    for p in set(persons.tolist()):
        own = persons == p
        sd = x[own].std(0)
        out[own] = (x[own] - x[own].mean(0)) / np.where(sd > 1e-12, sd, 1.0)
    return out


def nearest_class_mean(x_train: np.ndarray, y: np.ndarray, x_test: np.ndarray) -> np.ndarray:
    """Size classes (B',) of the rows of `x_test` (B', K) by the nearest (Euclidean) class mean of
    `x_train` (B, K) with classes `y` (B,); a class absent from `y` is never chosen."""
    means = np.stack([x_train[y == k].mean(0) if np.any(y == k) else np.full(x_train.shape[1], np.inf)
                      for k in range(N_SIZES)])
    return np.argmin(np.sum((x_test[:, None] - means[None]) ** 2, axis=-1), axis=1)


def predict_aperture(Z_train, y, Z_test) -> np.ndarray:
    """Nearest class mean (Euclidean) of the largest apertures so far (thumb–index, thumb–middle)."""
    return nearest_class_mean(max_apertures(Z_train), y, max_apertures(Z_test))


def predict_aperture_person(Z_train, y, persons: np.ndarray, Z_test) -> np.ndarray:
    """`predict_aperture` on the largest apertures z-scored per person (training persons `persons`
    (B,); the test sequences are one person's)."""
    train = standardise_per_person(max_apertures(Z_train), persons)
    test = standardise_per_person(max_apertures(Z_test), np.zeros(len(Z_test), int))
    return nearest_class_mean(train, y, test)


def predict_regression(Z_train, y, Z_test) -> np.ndarray:
    """Least squares from the last frame's features to the size in cm, snapped."""
    def design(Z):
        return np.column_stack([np.stack([z[-1] for z in Z]), np.ones(len(Z))])

    coef, *_ = np.linalg.lstsq(design(Z_train), SIZE_CM[y], rcond=None)
    return snap(design(Z_test) @ coef)


def dtw_distances(query: np.ndarray, refs: list[np.ndarray]) -> np.ndarray:
    """DTW distances (B,) of one (L, D) sequence to each reference (tslearn's definition: the square
    root of the smallest sum of squared Euclidean frame distances along a warping path with steps
    (1, 0), (0, 1), (1, 1)), all references at once, one anti-diagonal of the table per step."""
    R, lengths = pad(refs)
    R, lengths = R[:len(refs)], lengths[:len(refs)]
    cost = np.sum((query[None, :, None, :] - R[:, None, :, :]) ** 2, axis=-1)  # (B, La, Lb)
    la, lb = len(query), R.shape[1]
    table = np.full((len(refs), la + 1, lb + 1), np.inf)
    table[:, 0, 0] = 0.0
    for d in range(2, la + lb + 1):
        i = np.arange(max(1, d - lb), min(la, d - 1) + 1)
        j = d - i
        best = np.minimum(np.minimum(table[:, i - 1, j], table[:, i - 1, j - 1]), table[:, i, j - 1])
        table[:, i, j] = cost[:, i - 1, j - 1] + best
    return np.sqrt(table[np.arange(len(refs)), la, lengths])


def predict_dtw(Z_train, y, Z_test) -> np.ndarray:
    """1-nearest neighbour under DTW among the training sequences."""
    return np.array([y[np.argmin(dtw_distances(z, Z_train))] for z in Z_test])


def settings_grid(method: str, cfg) -> list[Setting]:
    """The settings `select_setting` chooses from: corners × covariances × states × floors for the
    PHMM, states × floors for hmmlearn."""
    grids = cfg.phmm_grids if method == "phmm" else (None,)
    tied = [c == "tied" for c in cfg.phmm_covariances] if method == "phmm" else (False,)
    return [Setting(n, f, g, t) for g in grids for t in tied for n in cfg.grid_states for f in cfg.floors]


def full_predict(method: str, Z_train, y, Z_test, setting: Setting, cfg) -> np.ndarray:
    """Size classes of whole test reaches by `method` ('phmm' or 'hmmlearn') with `setting`."""
    if method == "phmm":
        phmm = fit_phmm(Z_train, y, setting, cfg)
        if cfg.search:
            phi = recognise_phmm(phmm, Z_test, cfg)
        else:
            profile, lengths = prefix_profile(phmm, Z_test, cfg)
            phi = phi_lattice(cfg)[np.argmax(profile_at(profile, lengths, 1.0), axis=0)]
        return snap(phi_to_cm(phi, setting.grid))
    return predict_hmmlearn(fit_hmmlearn(Z_train, y, setting, cfg), Z_test)


def select_setting(method: str, seqs: list[np.ndarray], y: np.ndarray, persons: np.ndarray, cfg
                   ) -> tuple[Setting, dict[str, float]]:
    """The setting of `method` with the best mean size accuracy on inner leave-one-person-out folds of
    the training persons (the first `cfg.n_validation_folds` of them; ties go to the earlier
    setting). Returns (setting, {str(setting): mean validation accuracy})."""
    grid = settings_grid(method, cfg)
    held = sorted(set(persons.tolist()))[:cfg.n_validation_folds]
    if len(grid) == 1 or len(held) < 2:
        return grid[0], {}
    scores = {}
    for setting in grid:
        accs = []
        for person in held:
            inner = persons != person
            Z_in, Z_val = standardise([s for s, k in zip(seqs, inner) if k], [s for s, k in zip(seqs, inner) if not k])
            accs.append(np.mean(full_predict(method, Z_in, y[inner], Z_val, setting, cfg) == y[~inner]))
        scores[str(setting)] = float(np.mean(accs))
    best = max(range(len(grid)), key=lambda k: (scores[str(grid[k])], -k))
    return grid[best], scores
