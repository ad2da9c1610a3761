"""The evaluation protocol of the OAC recordings, shared by the studies that recognise actions and
objects on them (ECCV 2008 §5, Tables 2-4; LfD 2009 §V, Table I): the features, the leave-one-person-out
folds (every CRF of the papers trained per fold, early stopping on a validation person), CHCRF fusion
(eq. 8), the error tables, and the papers' numbers to compare them with.

A "run" is one complete leave-one-person-out pass: each person in turn is the test set, the models are
trained on the others; the runs differ in the validation person of each fold (drawn from the seed and
the run index) and in the HCRF's initialisation. Tables give the median and max error % over the runs.
"""
from __future__ import annotations

import dataclasses

import numpy as np

import crf_jax
from experiments.config import progress
from experiments.data import oac

# The papers' numbers: (median, max) error % of ECCV 2008 Tables 2-4 (None: not given), % correct of LfD
# 2009 Table I.
PAPER_TABLE2 = {
    "actions": {"crf_conn0": (5.3, 9.3), "crf_conn1": (6.0, 12.7), "crf_conn2": (10.7, 18.7),
                "hcrf_conn0": (14.7, 21.3), "baseline": (17.3, 20.0)},
    "objects": {"crf_conn0": (8.0, 8.7), "crf_conn1": (11.3, 13.3), "crf_conn2": (20.7, 28.0),
                "hcrf_conn0": (24.7, 28.7), "baseline": (8.7, None)},
}
PAPER_TABLE3 = {"actions": {"chcrf": (3.3, 4.7), "fcrf": (5.3, 8.0), "separate_crf": (5.3, 9.3)},
                "objects": {"chcrf": (3.3, 4.7), "fcrf": (6.0, 12.0), "separate_crf": (8.0, 8.7)}}
PAPER_TABLE4 = {"xa_xo": (3.3, 4.7), "pa_xo": (2.7, 8.0), "xa_x1o": (4.7, 8.7), "pa_x1o": (14.7, 18.0)}
PAPER_LFD_CORRECT = {"2d": {"shape_and_pos": 95.3, "pos_only": 80.0}, "3d": {"shape_and_pos": 95.3, "pos_only": 85.3}}
TABLE4_CELLS = {  # cell -> (action classifier, object classifier)
    "xa_xo": ("crf_conn0", "crf_conn0"), "pa_xo": ("baseline_pos2d", "crf_conn0"),
    "xa_x1o": ("crf_conn0", "baseline_first_frame"), "pa_x1o": ("baseline_pos2d", "baseline_first_frame"),
}


@dataclasses.dataclass(frozen=True)
class ProtocolOptions:
    """The protocol's settings: the jackknife and the training of every model.

    Attributes:
        seed: the validation persons' draws and the HCRF's initialisation.
        n_persons: persons 0 .. n_persons - 1 take turns as the test person, >= 3 (test, validation
            and training persons).
        n_runs: complete leave-one-person-out passes, >= 1.
        l2: CRFsuite's c2 for every CRF, >= 0.
        svm_l2: the first-frame SVM's L2 weight, >= 0.
        n_hidden: HCRF hidden states per class, >= 1.
        max_iter: L-BFGS iterations (early stopping on the validation person), >= 1.
        cooc_smoothing: K(a, o) = (count + smoothing) / sum, >= 0.
    """

    seed: int = 0
    n_persons: int = 10
    n_runs: int = 9
    l2: float = 1.0
    svm_l2: float = 0.01
    n_hidden: int = 3
    max_iter: int = 100
    cooc_smoothing: float = 0.01

    def __post_init__(self):
        if self.n_persons < 3:
            raise ValueError("n_persons: need at least 3 (test, validation and training persons)")
        if self.n_runs < 1 or self.max_iter < 1 or self.n_hidden < 1:
            raise ValueError("n_runs, max_iter and n_hidden must be positive")
        if self.l2 < 0 or self.svm_l2 < 0 or self.cooc_smoothing < 0:
            raise ValueError("l2, svm_l2 and cooc_smoothing must be >= 0")


def feature_sets(data: oac.OACData) -> dict[str, np.ndarray]:
    """Per-frame feature sequences (N, T, D): action [p, hand HOG] in 2-D and 3-D, positions only, objects."""
    return {
        "action2d": np.concatenate([data.pos2d, data.hand_hog], axis=-1),
        "action3d": np.concatenate([data.pos3d, data.hand_hog], axis=-1),
        "pos2d": data.pos2d, "pos3d": data.pos3d, "object": data.object_hog,
        "joint": np.concatenate([data.pos2d, data.hand_hog, data.object_hog], axis=-1),
    }


def standardise(X: np.ndarray, lengths: np.ndarray, train: np.ndarray) -> np.ndarray:
    """z-score every feature dimension with the mean and std of the valid frames of the `train` rows;
    padding frames stay 0. X (N, T, D), lengths (N,), train (N,) bool -> (N, T, D) float32."""
    valid = np.arange(X.shape[1])[None] < lengths[:, None]  # (N, T)
    frames = X[train][valid[train]]
    mean, std = frames.mean(axis=0), frames.std(axis=0)
    out = (X - mean) / np.where(std > 1e-8, std, 1.0)
    return np.where(valid[..., None], out, 0.0).astype(np.float32)


def labels_per_frame(y: np.ndarray, T: int) -> np.ndarray:
    """Each recording's label on every one of its T frames: y (N,) -> (N, T)."""
    return np.repeat(y[:, None], T, axis=1)


# ------------------------------------------------------------------------------------------- folds
def fold_scores(data: oac.OACData, feats: dict, test_person: int, val_person: int, options: ProtocolOptions,
                seed: int) -> dict:
    """Train every model on the persons other than `test_person` and `val_person` (early stopping on
    `val_person`); return log-scores on the test recordings: name -> (n_test, K) or (n_test, Ka, Ko)."""

    lens = data.lengths
    test, val = data.person == test_person, data.person == val_person
    train = ~(test | val)
    ya, yo = data.action, data.object
    scores: dict[str, np.ndarray] = {}
    kw = dict(l2=options.l2, options=crf_jax.FitOptions(max_iter=options.max_iter))

    def chain(name: str, key: str, y: np.ndarray, connectivity: int = 0):
        X = standardise(feats[key], lens, train)
        T = X.shape[1]
        model, _ = crf_jax.fit_chain(X[train], labels_per_frame(y[train], T), lens[train], n_labels=oac.N_CLASSES,
                                     connectivity=connectivity,
                                     validation=(X[val], labels_per_frame(y[val], T), lens[val]), **kw)
        scores[name] = np.asarray(crf_jax.segment_log_probs(model, X[test], lens[test]))

    for c in (0, 1, 2):
        chain(f"action/crf_conn{c}", "action2d", ya, c)
        chain(f"object/crf_conn{c}", "object", yo, c)
    chain("action/baseline_pos2d", "pos2d", ya)
    chain("action/crf_conn0_3d", "action3d", ya)
    chain("action/baseline_pos3d", "pos3d", ya)
    for target, key, y in (("action", "action2d", ya), ("object", "object", yo)):
        X = standardise(feats[key], lens, train)
        model, _ = crf_jax.fit_hcrf(X[train], y[train], lens[train], n_labels=oac.N_CLASSES, n_hidden=options.n_hidden,
                                    seed=seed, validation=(X[val], y[val], lens[val]), **kw)
        scores[f"{target}/hcrf_conn0"] = np.asarray(crf_jax.hcrf_log_probs(model, X[test], lens[test]))
    first = feats["object"][:, 0]
    mean, std = first[train].mean(axis=0), first[train].std(axis=0) + 1e-8
    first = ((first - mean) / std).astype(np.float32)
    svm, _ = crf_jax.fit_linear(first[train], yo[train], kind="svm", n_labels=oac.N_CLASSES, l2=options.svm_l2,
                                validation=(first[val], yo[val]),
                                options=crf_jax.FitOptions.for_linear("svm", max_iter=5 * options.max_iter))
    scores["object/baseline_first_frame"] = np.asarray(crf_jax.linear_log_proba(svm, first[test]))
    X = standardise(feats["joint"], lens, train)
    T = X.shape[1]
    fcrf, _ = crf_jax.fit_fcrf(X[train], labels_per_frame(ya[train], T), labels_per_frame(yo[train], T), lens[train],
                               n_actions=oac.N_CLASSES, n_objects=oac.N_CLASSES, inference="exact",
                               validation=(X[val], labels_per_frame(ya[val], T), labels_per_frame(yo[val], T),
                                           lens[val]), **kw)
    scores["pair/fcrf"] = np.asarray(crf_jax.fcrf_segment_log_probs(fcrf, X[test], lens[test]))
    scores["pair/cooccurrence"] = np.broadcast_to(
        crf_jax.cooccurrence(ya[train], yo[train], oac.N_CLASSES, oac.N_CLASSES, smoothing=options.cooc_smoothing),
        (int(test.sum()), oac.N_CLASSES, oac.N_CLASSES))
    return scores


def fused_predictions(scores: dict, action: str, obj: str) -> tuple[np.ndarray, np.ndarray]:
    """CHCRF (eq. 8): argmax over (a, o) of K(a, o) P(a | x) P(o | x). Returns actions (n,), objects (n,)."""

    cooc = scores["pair/cooccurrence"][0]
    joint = np.asarray(crf_jax.fuse(scores[f"action/{action}"], scores[f"object/{obj}"], cooc).log_joint)
    flat = joint.reshape(len(joint), -1).argmax(axis=1)
    return flat // oac.N_CLASSES, flat % oac.N_CLASSES


def run_predictions(data: oac.OACData, feats: dict, options: ProtocolOptions, run: int, test_persons) -> dict:
    """One leave-one-person-out pass: predicted labels of every recording per (target, method)."""
    rng = np.random.default_rng([options.seed, run])
    preds: dict[str, np.ndarray] = {}
    n = len(data.action)
    for p in test_persons:
        others = [q for q in range(options.n_persons) if q != p]
        val_person = int(rng.choice(others))
        s = fold_scores(data, feats, p, val_person, options, seed=options.seed * 1000 + run)
        test = np.flatnonzero(data.person == p)
        out = {k.replace("/", ":"): v.argmax(axis=1) for k, v in s.items() if k.startswith(("action/", "object/"))}
        fj = s["pair/fcrf"].reshape(len(test), -1).argmax(axis=1)
        out["action:fcrf"], out["object:fcrf"] = fj // oac.N_CLASSES, fj % oac.N_CLASSES
        for cell, (a, o) in TABLE4_CELLS.items():
            out[f"action:chcrf_{cell}"], out[f"object:chcrf_{cell}"] = fused_predictions(s, a, o)
        for key, value in out.items():
            preds.setdefault(key, np.full(n, -1))[test] = value
    return preds


def error_pct(preds: dict, data: oac.OACData, mask: np.ndarray) -> dict[str, float]:
    """Error % over the recordings in `mask` for every predicted (target:method)."""
    truth = {"action": data.action, "object": data.object}
    return {k: float(100.0 * np.mean(v[mask] != truth[k.split(":")[0]][mask])) for k, v in preds.items()}


def _stat(errors: list[dict], key: str) -> dict[str, float]:
    vals = np.array([e[key] for e in errors])
    return {"median": float(np.median(vals)), "max": float(np.max(vals))}


def tables(errors: list[dict]) -> dict:
    """The papers' four tables as nested {median, max} error % dicts."""
    st = lambda key: _stat(errors, key)  # noqa: E731
    return {
        "table2": {
            "actions": {"crf_conn0": st("action:crf_conn0"), "crf_conn1": st("action:crf_conn1"),
                        "crf_conn2": st("action:crf_conn2"), "hcrf_conn0": st("action:hcrf_conn0"),
                        "baseline": st("action:baseline_pos2d")},
            "objects": {"crf_conn0": st("object:crf_conn0"), "crf_conn1": st("object:crf_conn1"),
                        "crf_conn2": st("object:crf_conn2"), "hcrf_conn0": st("object:hcrf_conn0"),
                        "baseline": st("object:baseline_first_frame")},
        },
        "table3": {t: {"chcrf": st(f"{k}:chcrf_xa_xo"), "fcrf": st(f"{k}:fcrf"), "separate_crf": st(f"{k}:crf_conn0")}
                   for t, k in (("actions", "action"), ("objects", "object"))},
        "table4": {cell: {"actions": st(f"action:chcrf_{cell}"), "objects": st(f"object:chcrf_{cell}")}
                   for cell in TABLE4_CELLS},
        "table_lfd": {
            "2d": {"shape_and_pos": st("action:crf_conn0"), "pos_only": st("action:baseline_pos2d")},
            "3d": {"shape_and_pos": st("action:crf_conn0_3d"), "pos_only": st("action:baseline_pos3d")},
        },
    }


def evaluate(options: ProtocolOptions, data: oac.OACData, test_persons=None) -> tuple[dict, list[dict]]:
    """All runs of the jackknife on `data`; returns (tables, per-run error dicts)."""
    feats = feature_sets(data)
    test_persons = list(range(options.n_persons)) if test_persons is None else list(test_persons)
    mask = np.isin(data.person, test_persons)
    errors = [error_pct(run_predictions(data, feats, options, r, test_persons), data, mask)
              for r in progress(range(options.n_runs), desc="jackknife runs")]
    return tables(errors), errors


def with_units(tree: dict) -> dict:
    """The tables with their unit: every {median, max} cell becomes {"error_pct": cell}, so that the
    flat keys read e.g. `table2_actions_crf_conn0_error_pct_median`."""
    if set(tree) <= {"median", "max"}:
        return {"error_pct": dict(tree)}
    return {k: with_units(v) for k, v in tree.items()}
