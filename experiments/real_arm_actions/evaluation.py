"""Folds and their evaluation: every method trained on a fold's training persons (settings chosen on
validation folds inside them), tested on its held-out persons, timed; the side PHMMs on the same
folds.

A fold is (training `Dataset`, test `Dataset`): leave-one-person-out over one folder's persons, or
one fold of all persons of a training folder against all persons of a test folder (`--train`,
`--test`). Accuracy per held-out person; the study's accuracy is their mean.
"""
from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

import phmm_jax as P
from experiments.timing import time_call
from experiments.config import progress
from experiments.real_arm_actions import methods as mt
from experiments.real_arm_actions.config import METHODS
from experiments.real_arm_actions.data import Dataset


class MethodResult(NamedTuple):
    """One method over all folds: predicted (B,) labels of the concatenated test sets, truth (B,),
    test persons (B,), chosen settings and validation accuracies per fold, seconds spent."""

    predicted: np.ndarray
    truth: np.ndarray
    person: np.ndarray
    settings: list
    validation: list
    train_s: float
    test_s: float
    selection_s: float
    train_s_per_fold: list

    def per_person(self) -> dict[str, float]:
        return {p: float(np.mean(self.predicted[self.person == p] == self.truth[self.person == p]))
                for p in sorted(set(self.person.tolist()))}

    @property
    def accuracy(self) -> float:
        """Mean over the held-out persons."""
        return float(np.mean(list(self.per_person().values())))

    def confusion(self) -> np.ndarray:
        counts = np.zeros((mt.N_ACTIONS, mt.N_ACTIONS), int)
        np.add.at(counts, (self.truth, self.predicted), 1)
        return counts


def leave_one_person_out(data: Dataset) -> list[tuple[Dataset, Dataset]]:
    return [(data.subset(data.person != p), data.subset(data.person == p)) for p in data.persons]


def _timed(fn, block: bool):
    timing = time_call(fn, repeats=1, warmup=None, block=block)
    return timing.result, timing.median_s


def run_method(method: str, folds, cfg, rng: np.random.Generator) -> MethodResult:
    """Select, train and test `method` on every fold; train/test times exclude the selection (JAX
    compilation is inside the first folds' times: `train_s_per_fold` shows it)."""
    predicted, truth, person, settings, validation, train_times = [], [], [], [], [], []
    test_s = selection_s = 0.0
    block = method in ("edhmm", "hmm")
    for train, test in progress(folds, desc=f"{method} ({folds[0][0].kind})"):
        t0 = time.perf_counter()
        setting, scores = mt.select_setting(method, train.features, train.action, train.person, cfg, rng)
        selection_s += time.perf_counter() - t0
        X_train, X_test = mt.standardise(train.features, test.features)
        model, seconds = _timed(lambda: mt.FIT[method](X_train, train.action, setting, cfg), block)
        train_times.append(seconds)
        labels, seconds = _timed(lambda: mt.PREDICT[method](model, X_test), block=False)
        test_s += seconds
        predicted.append(labels)
        truth.append(test.action)
        person.append(test.person)
        settings.append(setting)
        validation.append(scores)
    return MethodResult(np.concatenate(predicted), np.concatenate(truth), np.concatenate(person), settings,
                        validation, float(sum(train_times)), test_s, selection_s, train_times)


class SideResult(NamedTuple):
    """The side PHMMs over all folds: recognised action (B,), phi of the true action's PHMM (B,),
    true action, side (0 left, 1 right) and person (B,); seconds training and recognising; the
    regression baseline's side estimate (B,) (`side_regression`); the covariance floor chosen in each fold.
    Training time includes the floor's selection."""

    action: np.ndarray
    phi: np.ndarray
    truth: np.ndarray
    side: np.ndarray
    person: np.ndarray
    train_s: float
    test_s: float
    regression: np.ndarray
    floors: tuple[float, ...]

    @property
    def side_correct(self) -> np.ndarray:
        return (self.phi > 0.5) == (self.side == 1)

    @property
    def regression_correct(self) -> np.ndarray:
        return (self.regression > 0.5) == (self.side == 1)

    def per_person(self, correct: np.ndarray) -> dict[str, float]:
        return {p: float(np.mean(correct[self.person == p])) for p in sorted(set(self.person.tolist()))}


def side_regression(train: Dataset, test: Dataset) -> np.ndarray:
    """The baseline beside the side PHMMs: per action, an affine least-squares map from the
    final fingertip positions to the side (0 left, 1 right), fitted on the training persons. "Final":
    the frame farthest from the trial's first in those features. Markers: both fingertips (RFTP, LFTP
    relative to the sternum); the angle files have no fingertip, so there all their columns. Returns
    the side estimate (B_test,)."""
    columns = [k for k, n in enumerate(train.names) if "FTP" in n] if train.kind == "markers" else slice(None)

    def final(features):
        f = features[:, :, columns]
        hold = np.argmax(np.linalg.norm(f - f[:, :1], axis=-1), axis=1)
        return np.concatenate([f[np.arange(len(f)), hold], np.ones((len(f), 1))], axis=1)

    f_train, f_test = final(train.features), final(test.features)
    out = np.zeros(len(f_test))
    for a in np.unique(test.action):
        coef, *_ = np.linalg.lstsq(f_train[train.action == a], train.side[train.action == a].astype(float), rcond=None)
        out[test.action == a] = f_test[test.action == a] @ coef
    return out


def _side_models(train: Dataset, X_train: np.ndarray, setting, floor: float, cfg) -> list[P.PHMM] | None:
    """Per action a 1-D PHMM over the side (corner φ = 0: the left-arm trials, φ = 1: the right-arm
    ones) with covariance floor `floor`; None when `train` lacks one side of an action."""
    groups = [[X_train[(train.action == a) & (train.side == s)] for s in (0, 1)] for a in range(mt.N_ACTIONS)]
    if any(len(g) == 0 for pair in groups for g in pair):
        return None
    config = mt.ed_config(setting, X_train.shape[1], cfg.duration_spread)
    options = P.FitOptions(max_iter=cfg.n_iter, reg_covar=floor)
    return [P.fit_phmm(pair, (2,), config, options=options) for pair in groups]


def _side_phi(phmms, X_test: np.ndarray, action: np.ndarray, cfg) -> tuple[np.ndarray, np.ndarray]:
    """(recognised action (B,), φ of the true action's PHMM (B,))."""
    rec = P.recognize(phmms, X_test, n_steps=cfg.recognition_steps)
    return np.asarray(rec.label), np.asarray(rec.phi)[np.arange(len(X_test)), action, 0]


def select_side_floor(train: Dataset, setting, cfg, rng: np.random.Generator) -> tuple[float, dict[str, float]]:
    """The covariance floor of the side PHMMs (`cfg.side_floors`) with the lowest mean |φ − side| over
    `cfg.n_validation_folds` inner leave-one-person-out folds of the training persons (drawn by
    `rng`; ties go to the smaller floor). With a few training persons the learnt covariances are the
    spread of those persons only, and a new person's offsets are far outside it; φ then moves towards
    the other corner, whose covariances are wider, instead of saying which arm moved.
    Returns (floor, {str(floor): mean validation |φ − side|})."""
    persons = sorted(set(train.person.tolist()))
    if len(cfg.side_floors) == 1 or len(persons) < 2:
        return cfg.side_floors[0], {}
    held = rng.permutation(persons)[:cfg.n_validation_folds]  # the same validation persons for every floor
    scores = {}
    for floor in cfg.side_floors:
        errors = []
        for person in held:
            inner_train, inner_val = train.subset(train.person != person), train.subset(train.person == person)
            X_train, X_val = mt.standardise(inner_train.features, inner_val.features)
            phmms = _side_models(inner_train, X_train, setting, floor, cfg)
            if phmms is None:
                return cfg.side_floors[0], {}
            errors.append(np.abs(_side_phi(phmms, X_val, inner_val.action, cfg)[1] - inner_val.side))
        scores[str(floor)] = float(np.mean(np.concatenate(errors)))
    best = min(range(len(cfg.side_floors)), key=lambda k: (scores[str(cfg.side_floors[k])], k))
    return cfg.side_floors[best], scores


def run_side_phmm(folds, settings: list, cfg, rng: np.random.Generator) -> SideResult | None:
    """Per fold and action a 1-D PHMM over the reach side (synchronised local training, PHMM §III-B1)
    with the explicit-duration setting the fold chose for `edhmm` and the covariance floor
    `select_side_floor` chose on the fold's training persons; recognition (PHMM eq. 3) gives the
    action and φ; φ > 0.5 reads "right". None when a training fold lacks one side of an action."""
    out = {k: [] for k in ("action", "phi", "truth", "side", "person", "regression")}
    train_s = test_s = 0.0
    floors = []
    for (train, test), setting in zip(progress(folds, desc=f"side PHMMs ({folds[0][0].kind})"), settings):
        (floor, _), seconds = _timed(lambda: select_side_floor(train, setting, cfg, rng), False)
        floors.append(floor)
        X_train, X_test = mt.standardise(train.features, test.features)
        phmms, seconds_fit = _timed(lambda: _side_models(train, X_train, setting, floor, cfg), True)
        if phmms is None:
            return None
        train_s += seconds + seconds_fit
        (action, phi), seconds = _timed(lambda: _side_phi(phmms, X_test, test.action, cfg), False)
        test_s += seconds
        for key, value in (("action", action), ("phi", phi), ("truth", test.action), ("side", test.side),
                           ("person", test.person), ("regression", side_regression(train, test))):
            out[key].append(value)
    return SideResult(*(np.concatenate(out[k]) for k in ("action", "phi", "truth", "side", "person")),
                      train_s, test_s, np.concatenate(out["regression"]), tuple(floors))


def evaluate(folds, cfg) -> tuple[dict[str, MethodResult], SideResult | None]:
    """Every method of `METHODS` on `folds` (one generator per method, from the seed), then the side
    PHMMs with the explicit-duration settings chosen for `edhmm`."""
    results = {m: run_method(m, folds, cfg, np.random.default_rng([cfg.seed, k])) for k, m in enumerate(METHODS)}
    side_rng = np.random.default_rng([cfg.seed, len(METHODS)])
    return results, run_side_phmm(folds, results["edhmm"].settings, cfg, side_rng)
