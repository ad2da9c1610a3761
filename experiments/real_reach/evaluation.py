"""Leave-one-person-out folds of the size classifiers and the event detectors: every setting chosen
on the training persons of a fold, every figure on its held-out person."""
from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from experiments.config import progress
from experiments.real_reach import events as evt
from experiments.real_reach import methods as mt
from experiments.real_reach.config import METHODS
from experiments.real_reach.data import (Movement, calibrate, event_features,
                                         reach_features)


class SizeResult(NamedTuple):
    """Predicted size classes per method and prefix fraction ({method: {fraction: (B,)}}) over the
    concatenated held-out persons; truth and person (B,); the PHMM's recognised φ on whole reaches
    (B,) and its cm estimate; the φ lattice's answer on whole reaches; the settings chosen per fold
    and their validation accuracies;
    PHMM diagnostics per reach: the log-likelihood's range over φ in [0, 1] per frame, and the gap
    between the best lattice φ and the true size's φ (nats); recognition seconds per reach; the PHMM's corners per fold; the search's ε."""

    predicted: dict
    truth: np.ndarray
    person: np.ndarray
    phi: np.ndarray
    phmm_cm: np.ndarray
    lattice_full: np.ndarray
    settings: dict
    validation: dict
    ll_range_per_frame: np.ndarray
    ll_gap_true: np.ndarray
    recognition_s_per_reach: float
    grids: list
    epsilon: float

    def accuracy(self, method: str, fraction: float = 1.0) -> float:
        """Pooled share of the held-out reaches whose size is right."""
        return float(np.mean(self.predicted[method][fraction] == self.truth))

    def per_person(self, method: str, fraction: float = 1.0) -> dict[str, float]:
        """Accuracy per held-out person ('P1', ...)."""
        p = self.predicted[method][fraction]
        return {f"P{q}": float(np.mean(p[self.person == q] == self.truth[self.person == q]))
                for q in sorted(set(self.person.tolist()))}

    def confusion(self, method: str, fraction: float = 1.0) -> np.ndarray:
        """(3, 3) counts, rows true size, columns recognised."""
        counts = np.zeros((mt.N_SIZES, mt.N_SIZES), int)
        np.add.at(counts, (self.truth, self.predicted[method][fraction]), 1)
        return counts

    @property
    def edge_share(self) -> float:
        """Share of recognised φ within 1e-3 of the search box's edge [−ε, 1 + ε]."""
        return float(np.mean((self.phi <= -self.epsilon + 1e-3) | (self.phi >= 1 + self.epsilon - 1e-3)))


def evaluate_sizes(movements: list[Movement], normalisation: str, cfg) -> SizeResult:
    """Every size method on every leave-one-person-out fold, on whole reaches and their prefixes
    (`cfg.fractions`), with the features of `normalisation`; PHMM and hmmlearn settings chosen on
    inner folds of the training persons."""
    y = np.array([m.size for m in movements])
    persons = np.array([m.person for m in movements])
    if normalisation == "calibrated":
        seqs = calibrate([reach_features(m, "person") for m in movements], persons)
    else:
        seqs = [reach_features(m, normalisation) for m in movements]
    lattice = mt.phi_lattice(cfg)
    out = {m: {f: [] for f in cfg.fractions} for m in METHODS}
    keep = {k: [] for k in ("truth", "person", "phi", "cm", "lattice", "range", "gap")}
    settings, validation, grids = {"phmm": [], "hmmlearn": []}, {"phmm": [], "hmmlearn": []}, []
    rec_s, n_rec = 0.0, 0
    for person in progress(sorted(set(persons.tolist())), desc=f"sizes ({normalisation})"):
        train = persons != person
        s_train = [s for s, k in zip(seqs, train) if k]
        s_test = [s for s, k in zip(seqs, train) if not k]
        y_train, y_test = y[train], y[~train]
        chosen = {}
        for method in ("phmm", "hmmlearn"):
            chosen[method], scores = mt.select_setting(method, s_train, y_train, persons[train], cfg)
            settings[method].append(chosen[method])
            validation[method].append(scores)
        Z_train, Z_test = mt.standardise(s_train, s_test)
        grid = chosen["phmm"].grid
        grids.append(grid)
        phmm = mt.fit_phmm(Z_train, y_train, chosen["phmm"], cfg)
        profile, lengths = mt.prefix_profile(phmm, Z_test, cfg)
        t0 = time.perf_counter()
        phis = mt.phi_by_fraction(phmm, Z_test, profile, lengths, cfg)
        rec_s += time.perf_counter() - t0
        n_rec += len(Z_test)
        phi = phis[1.0]
        cv_phis = mt.cross_validated_phi(s_train, y_train, persons[train], chosen["phmm"], cfg)
        hmms = mt.fit_hmmlearn(Z_train, y_train, chosen["hmmlearn"], cfg)
        for f in cfg.fractions:
            P_train, P_test = mt.prefixes(Z_train, f), mt.prefixes(Z_test, f)
            out["phmm"][f].append(mt.snap(mt.phi_to_cm(phis[f], grid)))
            out["phmm_cv"][f].append(mt.nearest_class_mean(cv_phis[f][:, None], y_train, phis[f][:, None]))
            out["phmm_person"][f].append(mt.nearest_class_mean(
                mt.standardise_per_person(cv_phis[f][:, None], persons[train]), y_train,
                mt.standardise_per_person(phis[f][:, None], persons[~train])))
            out["aperture"][f].append(mt.predict_aperture(P_train, y_train, P_test))
            out["aperture_person"][f].append(mt.predict_aperture_person(P_train, y_train, persons[train], P_test))
            out["regression"][f].append(mt.predict_regression(P_train, y_train, P_test))
            out["hmmlearn"][f].append(mt.predict_hmmlearn(hmms, P_test))
            out["dtw"][f].append(mt.predict_dtw(P_train, y_train, P_test))
        full = mt.profile_at(profile, lengths, 1.0)  # (G, B)
        inside = (lattice >= 0) & (lattice <= 1)
        true_phi = np.interp(mt.SIZE_CM[y_test], mt.phi_to_cm(lattice, grid), lattice)
        true_ll = np.array([np.interp(true_phi[b], lattice, full[:, b]) for b in range(len(y_test))])
        keep["truth"].append(y_test)
        keep["person"].append(persons[~train])
        keep["phi"].append(phi)
        keep["cm"].append(mt.phi_to_cm(phi, grid))
        keep["lattice"].append(mt.snap(mt.phi_to_cm(lattice[np.argmax(full, axis=0)], grid)))
        keep["range"].append((full[inside].max(0) - full[inside].min(0)) / lengths)
        keep["gap"].append(full.max(0) - true_ll)
    predicted = {m: {f: np.concatenate(v) for f, v in d.items()} for m, d in out.items()}
    result = SizeResult(predicted, *(np.concatenate(keep[k]) for k in ("truth", "person", "phi", "cm", "lattice")),
                        settings, validation, np.concatenate(keep["range"]), np.concatenate(keep["gap"]),
                        rec_s / max(n_rec, 1), grids, cfg.epsilon)
    return result


class EventResult(NamedTuple):
    """Per detector ('speed', 'hmm lag ℓ'): estimated − true onset and contact frames (B,), and the
    latency (frame the estimate was known − true frame) (B,) of both; persons (B,); the speed
    thresholds chosen per fold."""

    onset_error: dict
    contact_error: dict
    onset_latency: dict
    contact_latency: dict
    person: np.ndarray
    speed_params: list


def evaluate_events(movements: list[Movement], cfg) -> EventResult:
    """Both event detectors on every leave-one-person-out fold (fitted on the training persons)."""
    feats = [event_features(m) for m in movements]
    onsets = np.array([m.onset for m in movements])
    contacts = np.array([m.contact for m in movements])
    persons = np.array([m.person for m in movements])
    names = ["speed"] + [f"hmm lag {lag}" for lag in cfg.event_lags]
    acc = {k: {n: [] for n in names} for k in ("oe", "ce", "ol", "cl")}
    order, params = [], []
    for person in sorted(set(persons.tolist())):
        train = persons != person
        f_train = [f for f, k in zip(feats, train) if k]
        f_test = [f for f, k in zip(feats, train) if not k]
        p = evt.fit_speed(f_train, onsets[train], contacts[train], cfg)
        params.append(p)
        found = {"speed": evt.detect_speed(p, f_test, cfg)}
        model = evt.fit_event_hmm(f_train, onsets[train], contacts[train], cfg)
        for lag in cfg.event_lags:
            found[f"hmm lag {lag}"] = evt.detect_hmm(model, f_test, lag)
        for name, e in found.items():
            acc["oe"][name].append(e.onset - onsets[~train])
            acc["ce"][name].append(e.contact - contacts[~train])
            acc["ol"][name].append(e.onset_known - onsets[~train])
            acc["cl"][name].append(e.contact_known - contacts[~train])
        order.append(persons[~train])
    cat = {k: {n: np.concatenate(v) for n, v in d.items()} for k, d in acc.items()}
    return EventResult(cat["oe"], cat["ce"], cat["ol"], cat["cl"], np.concatenate(order), params)
