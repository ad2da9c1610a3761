"""Each OAC found in a long recording, classified (LfD 2009 §IV eqs. 9-10, §V, Fig. 8): the
CHCRF of eq. 9 (an action CRF on the 3-D hand position and hand HOG, an object CRF on the object
HOG, both pre-segmented (ECCV §4), fused with the co-occurrence rates K(a, o) of the training clips),
trained on the clips of the persons other than the recording's (as LfD §V: the demonstrator's own
clips removed); then the object-history prior of eq. 10 over the OACs before it, and Z(x) of eq. 9,
proportional to how plausible the OAC is.

Z(x) here is sum_(a, o) K(a, o) P(a | x) P(o | x) with P(a | x) the pre-segmented CRF's probability
of the constant labelling [a, ..., a] among the K constant labellings (ECCV §4: the segment has one
label), so Z is at most max K and does not shrink with the segment's length; `log_z_sequence` is the
same sum with P(a | x) normalised over all K^T labellings (`crf_jax.segment_log_probs` as it is),
which falls with every ambiguous frame of a long segment. The paper's Z(x) (10^7 seen, 85,000 and
45,000 unseen) used unnormalised potentials, so only orders of magnitude between OACs compare.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

import crf_jax
from experiments.data.oac import N_CLASSES, OACData
from experiments.data.video import ACTIONS, OBJECTS, UNSEEN
from experiments.lfd_demonstration.config import Config
from experiments.lfd_demonstration.features import FrameFeatures, as_oac_data, segment_frames
from experiments.data.oac_protocol import labels_per_frame, standardise

COOC_SMOOTHING = 0.01  # the OAC study's K(a, o) smoothing


class PeriodLabels(NamedTuple):
    """Per period (P,): log_joint (P, Ka, Ko) log P(a, o | x) of eq. 9; log_z (P,) log Z(x) over the
    constant labellings; log_joint_history (P, Ka, Ko) with eq. 10's prior over the earlier periods of
    the recording; log_z_sequence (P,) log Z(x) over all labellings (module docstring)."""

    log_joint: np.ndarray
    log_z: np.ndarray
    log_joint_history: np.ndarray
    log_z_sequence: np.ndarray


def _stack(a: OACData, b: OACData) -> OACData:
    """Two data sets as one (padded to the longer)."""
    T = max(a.pos2d.shape[1], b.pos2d.shape[1])
    pad = lambda x: np.pad(x, [(0, 0), (0, T - x.shape[1])] + [(0, 0)] * (x.ndim - 2)) if x.ndim > 1 else x  # noqa
    return OACData(*(np.concatenate([pad(x), pad(y)]) for x, y in zip(a, b)))


def _segment_scores(X: np.ndarray, data: OACData, y: np.ndarray, train, val, test, cfg: Config) -> np.ndarray:
    """log P(y_t = k for all t | x) (n_test, K) of a pre-segmented linear-chain CRF (connectivity 0)
    trained on the `train` rows, early-stopped on the `val` rows; features standardised on `train`."""
    Z = standardise(X, data.lengths, train)
    T = Z.shape[1]
    model, _ = crf_jax.fit_chain(Z[train], labels_per_frame(y[train], T), data.lengths[train], n_labels=N_CLASSES,
                                 validation=(Z[val], labels_per_frame(y[val], T), data.lengths[val]) if val.any()
                                 else None, options=crf_jax.FitOptions(max_iter=cfg.crf_max_iter))
    return np.asarray(crf_jax.segment_log_probs(model, Z[test], data.lengths[test]))


def _over_labels(log_p: np.ndarray) -> np.ndarray:
    """(B, K) log probabilities renormalised over the K labels (rows that are all -inf stay so)."""
    norm = np.logaddexp.reduce(log_p, axis=1, keepdims=True)
    return np.where(np.isfinite(norm), log_p - norm, log_p)


def chcrf_scores(cfg: Config, clips: OACData, person: int,
                 periods: OACData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CHCRF (eq. 9) of the `periods`: (log_joint (P, Ka, Ko), log_z (P,), log_z_sequence (P,); module
    docstring), trained on the clips of every person but `person`, one of them (drawn from the seed)
    held out for early stopping."""
    others = np.unique(clips.person[clips.person != person])
    if len(others) == 0:
        raise ValueError(f"person: no clips of another person than {person} to train the CHCRF")
    val_person = np.random.default_rng([cfg.seed, person]).choice(others) if len(others) > 1 else -1
    data = _stack(clips, periods)
    n, p = len(clips.action), len(periods.action)
    test = np.arange(n + p) >= n
    val = ~test & (data.person == val_person)
    train = ~test & ~val & (data.person != person)
    action = _segment_scores(np.concatenate([data.pos3d, data.hand_hog], -1), data, data.action, train, val, test, cfg)
    obj = _segment_scores(data.object_hog, data, data.object, train, val, test, cfg)
    cooc = crf_jax.cooccurrence(data.action[train], data.object[train], N_CLASSES, N_CLASSES, COOC_SMOOTHING)
    fused = crf_jax.fuse(action, obj, cooc)
    segment = crf_jax.fuse(_over_labels(action), _over_labels(obj), cooc)
    return (np.asarray(fused.log_joint, np.float64), np.asarray(segment.log_z, np.float64),
            np.asarray(fused.log_z, np.float64))


def with_history(log_joint: np.ndarray, start_positions: np.ndarray, end_positions: np.ndarray,
                 default_distance: float) -> np.ndarray:
    """Eq. 10 in recording order: period k's P(a, o | x) times the prior of the periods before it
    (their eq. 9 classifications and final hand positions against k's first hand position)."""
    out = np.empty_like(log_joint)
    for k in range(len(log_joint)):  # each OAC's prior depends on the ones before it
        prior = crf_jax.history_prior(np.exp(log_joint[:k]), end_positions[:k], start_positions[k], default_distance)
        out[k] = np.asarray(crf_jax.apply_history(log_joint[k], prior).log_joint)
    return out


def label_periods(cfg: Config, settings, clips: OACData, person: int, feats: FrameFeatures, hand_rc: np.ndarray,
                  starts: np.ndarray, stops: np.ndarray, scale: float) -> PeriodLabels:
    """The CHCRF labels of the periods [starts, stops) of one long recording by `person`, from its
    per-frame features `feats` and the tracked hand (row, column) `hand_rc` (T, 2)."""
    if len(starts) == 0:
        empty = np.zeros((0, N_CLASSES, N_CLASSES))
        return PeriodLabels(empty, np.zeros(0), empty, np.zeros(0))
    segments = [FrameFeatures(*(np.asarray(x)[segment_frames(a, b, settings.fps, cfg.feature_fps)] for x in feats))
                for a, b in zip(starts, stops)]
    none = np.full(len(segments), -1)
    periods = as_oac_data(segments, np.zeros_like(none), np.zeros_like(none), np.full_like(none, person), none)
    log_joint, log_z, log_z_sequence = chcrf_scores(cfg, clips, person, periods)
    history = with_history(log_joint, hand_rc[np.asarray(starts)], hand_rc[np.asarray(stops) - 1],
                           cfg.history_distance_px * scale)
    return PeriodLabels(log_joint, log_z, history, log_z_sequence)


def best_pairs(log_joint: np.ndarray) -> np.ndarray:
    """(P, 2) the (action, object) of highest probability of each period."""
    flat = log_joint.reshape(len(log_joint), -1).argmax(axis=1)
    return np.stack([flat // N_CLASSES, flat % N_CLASSES], axis=1)


def _z_summary(log_z: np.ndarray, truth: np.ndarray, prefix: str, suffix: str) -> dict:
    """Z(x) by OAC over the periods with a true OAC: medians over the seen and the unseen ones and per
    unseen combination, whether every seen Z is above every unseen one, and pitcher over binoculars."""
    known = truth[:, 0] >= 0
    z, pairs = np.exp(log_z[known]), truth[known]
    seen = pairs[:, 0] == pairs[:, 1]
    median = lambda sel: float(np.median(z[sel])) if sel.any() else float("nan")  # noqa: E731
    out = {f"{prefix}z_seen{suffix}": median(seen), f"{prefix}z_unseen{suffix}": median(~seen)}
    for a, o in UNSEEN:
        out[f"{prefix}z_{ACTIONS[a].replace(' ', '_')}_{OBJECTS[o]}{suffix}"] = median(
            (pairs[:, 0] == a) & (pairs[:, 1] == o))
    if seen.any() and (~seen).any():
        out[f"{prefix}z_seen_above_unseen{suffix}"] = bool(z[seen].min() > z[~seen].max())
    pitcher, binoculars = (out[f"{prefix}z_{ACTIONS[a].replace(' ', '_')}_{OBJECTS[o]}{suffix}"] for a, o in UNSEEN)
    if pitcher == pitcher and binoculars == binoculars:
        out[f"{prefix}z_pitcher_above_binoculars{suffix}"] = bool(pitcher > binoculars)
    return out


def label_metrics(labelled: list[dict]) -> dict:
    """Over every long recording: the found periods' labels and Z(x) (the pipeline end to end) and the
    true periods' (the oracle segmentation): correct rates (eq. 9, and with eq. 10's history), and
    whether Z orders the OACs as LfD §V reports (every seen OAC above every unseen one; drink from
    pitcher above pour from binoculars), for both normalisations of Z (module docstring)."""
    cat = lambda key, field: np.concatenate([getattr(r[key], field) for r in labelled])  # noqa: E731
    out = {}
    for key, prefix in (("found", ""), ("true", "true_periods_")):
        labels = PeriodLabels(*(cat(key, f) for f in PeriodLabels._fields))
        truth = np.concatenate([r[f"{key}_truth"] for r in labelled]).reshape(-1, 2)
        known = truth[:, 0] >= 0
        right = lambda lj: float(np.mean(np.all(best_pairs(lj[known]) == truth[known], axis=1))) \
            if known.any() else float("nan")  # noqa: E731
        out.update({f"{prefix}oacs": int(known.sum()), f"{prefix}oac_correct_rate": right(labels.log_joint),
                    f"{prefix}oac_correct_rate_history": right(labels.log_joint_history)})
        out.update(_z_summary(labels.log_z, truth, prefix, ""))
        out.update(_z_summary(labels.log_z_sequence, truth, prefix, "_sequence"))
    return out
