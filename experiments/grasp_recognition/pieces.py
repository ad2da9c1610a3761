"""Pieces of the grasp recognition protocol: database and held-out views, orientation errors, confusion,
the sensitivity sweeps (segmentation, HOG and kNN come from `lfd_jax.grasp`)."""
from __future__ import annotations

import numpy as np

import hog_jax
from experiments.config import progress
from experiments.data.grasp_database import grid_views
from experiments.grasp_recognition.config import Config, parse_grid
from lfd_common import quat_to_matrix
from lfd_jax.grasp import hog_features, knn_predict
from sim.grasping import GRASP_CLASSES, GRASP_MAPPINGS
from sim.grasping import ViewOptions, render_views


def bar(desc):
    return lambda it, total, d=None: progress(it, desc=d or desc, total=total)


def render_database(cfg: Config, n_azimuth: int, n_elevation: int):
    return grid_views(n_azimuth, n_elevation, cfg.render_size, cfg.crop_size,
                      progress=lambda it, total, desc: progress(it, desc=desc, total=total))


def held_out_views(cfg: Config):
    """Database-like views (database hand, black background) at random off-grid viewpoints, to tune LSH."""
    rng = np.random.default_rng([cfg.seed, 5, 9])
    per = max(1, cfg.n_held_out // len(GRASP_CLASSES))
    parts = [render_views(g, rng.uniform(0, 360, per), rng.uniform(0, 90, per),
                          ViewOptions(render_size=cfg.render_size, out_size=cfg.crop_size)) for g in GRASP_CLASSES]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def orientation_errors_deg(pred_euler, true_euler, pred_quat, true_quat) -> tuple[np.ndarray, np.ndarray]:
    """Absolute Euler-angle errors (N, 3) (azimuth and roll wrapped to [0, 180]) and the geodesic angle
    between the rotations (N,), in degrees."""
    d = np.degrees(np.asarray(pred_euler, float) - np.asarray(true_euler, float))
    d = np.abs((d + 180.0) % 360.0 - 180.0)
    dot = np.abs(np.sum(np.asarray(pred_quat, float) * np.asarray(true_quat, float), -1))
    return d, np.degrees(2.0 * np.arccos(np.clip(dot, 0.0, 1.0)))


# the order of each grasp object's rotational symmetry about its vertical axis (the world z axis, see
# `sim.grasp_objects`): cylinders, the disc and the ball have no defined azimuth, the cube one of 4 quarter turns
_SYMMETRY_ORDER = {1: 0, 2: 0, 4: 0, 9: 4, 10: 0, 12: 0}


def symmetric_errors_deg(pred_quat, true_quat, labels) -> np.ndarray:
    """(N,) geodesic error in degrees modulo the grasped object's symmetry about its axis: the smallest
    angle between R_true and Rz(θ) R_pred over the rotations Rz(θ) that map the object of class `labels`
    onto itself (every θ for the cylinders, disc and ball, in closed form: max_θ tr(Rz(θ) M) = M_zz +
    |(M_xx + M_yy, M_xy - M_yx)| for M = R_pred R_true^T; quarter turns for the cube). Rows with a NaN
    prediction give NaN."""
    p = quat_to_matrix(np.asarray(pred_quat, float))
    t = quat_to_matrix(np.asarray(true_quat, float))
    m = p @ np.swapaxes(t, -1, -2)
    order = np.array([_SYMMETRY_ORDER[GRASP_CLASSES[i]] for i in np.asarray(labels)], int)
    continuous = m[..., 2, 2] + np.hypot(m[..., 0, 0] + m[..., 1, 1], m[..., 0, 1] - m[..., 1, 0])
    quarter = [m[..., 2, 2] + np.cos(a) * (m[..., 0, 0] + m[..., 1, 1]) + np.sin(a) * (m[..., 0, 1] - m[..., 1, 0])
               for a in np.arange(4) * np.pi / 2]
    trace = np.where(order == 0, continuous, np.max(quarter, axis=0))
    return np.degrees(np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)))


def confusion(true, pred, n: int) -> np.ndarray:
    """(n, n + 1) counts: rows true class, columns predicted class, last column 'no hand found'."""
    c = np.zeros((n, n + 1), np.int64)
    np.add.at(c, (np.asarray(true), np.where(np.asarray(pred) < 0, n, pred)), 1)
    return c


def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a binomial proportion k / n."""
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return float(centre - half), float(centre + half)


def accuracy(pred, true) -> float:
    return float(np.mean(np.asarray(pred) == np.asarray(true))) if len(true) else float("nan")


def robot_accuracy(pred, true) -> dict:
    """Share of test images whose recognised grasp maps to the same robot preshape as the true one."""
    out = {}
    for mapping, hands in GRASP_MAPPINGS.items():
        for hand, table in hands.items():
            names = np.array([table[g] for g in GRASP_CLASSES] + ["none"])
            out[f"robot_grasp_accuracy_{mapping}_{hand}"] = float(np.mean(names[np.asarray(pred)] == names[true]))
    return out


def sweeps(cfg: Config, db, tests: dict, seg: dict, k: int) -> dict:
    """Accuracy (exact kNN) against k, against the database grid and for every (B, L)."""
    base = hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=cfg.n_levels)
    out = {"k": {}, "db": {}, "bl": {}}

    def evaluate(db_, config, ks):
        model = hog_jax.fit(hog_features(db_.images, db_.masks, np.ones(len(db_.labels), bool), config),
                            db_.labels, db_.euler, n_classes=len(GRASP_CLASSES), seed=cfg.seed)
        res = {}
        for name, t in tests.items():
            ok = seg[name].found
            x = hog_features(seg[name].images, seg[name].masks, ok, config)
            for kk in ks:
                res[(name, kk)] = accuracy(knn_predict(model, x, ok, min(kk, len(db_.labels)))[0], t.labels)
        return res

    for (name, kk), acc in evaluate(db, base, cfg.k_values).items():
        out["k"].setdefault(name, {})[kk] = acc
    for g in progress(cfg.db_grids, desc="database sizes"):
        a, e = parse_grid(g)
        for (name, _), acc in evaluate(render_database(cfg, a, e), base, (k,)).items():
            out["db"].setdefault(name, {})[a * e] = acc
    pairs = [(b, lv) for b in cfg.bins_sweep for lv in cfg.levels_sweep]
    for b, lv in progress(pairs, desc="B x L"):
        for (name, _), acc in evaluate(db, hog_jax.HOGConfig(n_bins=b, n_levels=lv), (k,)).items():
            out["bl"].setdefault(name, {})[(b, lv)] = acc
    return out
