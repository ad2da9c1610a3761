"""Grasp recognition from one image (GRASP: Kjellström, Romero & Kragic, IROS 2008, §III-B, §V, §VII).

    python -m experiments.grasp_recognition --preset quick|paper --out DIR

Database: the MuJoCo human hand (`sim.human_hand`, DEFAULT_SHAPE) in the six reference grasps
(`sim.human_grasps`) holding black objects, rendered from an azimuth x elevation grid over the upper
half-sphere (paper: 60 x 15 = 900 views per grasp, 6-degree steps), cropped and centred, HOG pyramid
(B = 4, L = 3) -> hyperplane LSH (tuned on held-out database-like views to recall@k >= 0.9) ->
distance-weighted kNN (eq. 3 class, eq. 4 orientation).

Tests (`experiments.data.grasp_tests`): a different hand (TEST_SHAPE) with perturbed postures, other
lighting, clutter, noise and blur; X (36 reach-to-grasp snapshots, two off-grid viewpoints per grasp),
X' (24, without the most neutral snapshots), X'' (12 completed grasps) and a large random set. Every
test frame goes through the `hog_jax` skin segmentation (skin model fitted on hands of other skin
tones and other clutter); a frame where no skin is found counts as an error.

Outputs: metrics.json, report.md, confusion.png (Fig. 7), orientation.png (Fig. 8), neighbours.png
(Fig. 5), sweeps.png (accuracy against k, database size, B x L), contact_sheet.png.
"""
from __future__ import annotations

import dataclasses
import json
import time

import sim  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
import jax
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hog_jax  # noqa: E402
from experiments.config import RunOutput, markdown_table, parse_config, progress  # noqa: E402
from experiments.data.grasp_tests import (STAGES, random_set, sequence_set, skin_training_pixels,  # noqa: E402
                                          stage_subsets)
from lfd_common import enable_compilation_cache  # noqa: E402
from sim.grasp_objects import GRASP_CLASSES, GRASP_MAPPINGS, GRASP_NAMES, robot_grasp_for  # noqa: E402
from sim.grasp_views import render_views, view_database  # noqa: E402

PAPER = {"accuracy_X": 0.61, "accuracy_Xp": 0.71, "accuracy_Xpp": 0.75, "human_X": 0.74,
         "orientation_error_deg": (0.0, 16.8, 10.5)}
_EULER_NAMES = ("azimuth", "elevation", "roll")


@dataclasses.dataclass(frozen=True)
class Config:
    """Grasp recognition from one image: rendered database, HOG, LSH kNN, GRASP's evaluation."""

    seed: int = 0
    n_azimuth: int = 60
    n_elevation: int = 15
    render_size: int = 128
    crop_size: int = 64
    n_bins: int = 4
    n_levels: int = 3
    k: int = 10
    lsh_target_recall: float = 0.9
    n_held_out: int = 120
    n_large: int = 600
    frame_size: int = 160
    n_skin_images: int = 12
    k_values: tuple[int, ...] = (1, 3, 5, 10, 20, 50)
    db_grids: tuple[str, ...] = ("30x10", "60x15", "120x30")
    bins_sweep: tuple[int, ...] = (3, 4, 5, 6, 8)
    levels_sweep: tuple[int, ...] = (2, 3, 4, 5)
    timing_repeats: int = 5

    def __post_init__(self):
        if min(self.n_azimuth, self.n_elevation, self.k, self.n_large, self.n_held_out, self.timing_repeats) < 1:
            raise ValueError("n_azimuth, n_elevation, k, n_large, n_held_out and timing_repeats must be >= 1")
        if not 0.0 < self.lsh_target_recall <= 1.0:
            raise ValueError("lsh_target_recall: must be in (0, 1]")
        if self.crop_size < 2 ** (max(self.levels_sweep + (self.n_levels,)) - 1):
            raise ValueError("crop_size: too small for the finest HOG level")
        for g in self.db_grids:
            _grid(g)


PRESETS = {
    "quick": {"n_azimuth": 30, "n_elevation": 8, "n_large": 60, "n_held_out": 60, "k_values": (1, 5, 10, 20),
              "db_grids": ("20x5", "30x8"), "bins_sweep": (3, 8), "levels_sweep": (2, 3), "timing_repeats": 3},
    "paper": {},
}


def _grid(text: str) -> tuple[int, int]:
    """'60x15' -> (60, 15)."""
    try:
        a, e = (int(v) for v in text.lower().split("x"))
    except ValueError as err:
        raise ValueError(f"db_grids: expected entries like '60x15', got {text!r}") from err
    if a < 1 or e < 1:
        raise ValueError(f"db_grids: expected positive grid sizes, got {text!r}")
    return a, e


def _bar(desc):
    return lambda it, total, d=None: progress(it, desc=d or desc, total=total)


def _database(cfg: Config, n_azimuth: int, n_elevation: int):
    return view_database(GRASP_CLASSES, n_azimuth, n_elevation, render_size=cfg.render_size, out_size=cfg.crop_size,
                         progress=lambda it, total, desc: progress(it, desc=desc, total=total))


def _held_out(cfg: Config):
    """Database-like views (database hand, black background) at random off-grid viewpoints, to tune LSH."""
    rng = np.random.default_rng([cfg.seed, 5, 9])
    per = max(1, cfg.n_held_out // len(GRASP_CLASSES))
    parts = [render_views(g, rng.uniform(0, 360, per), rng.uniform(0, 90, per), render_size=cfg.render_size,
                          out_size=cfg.crop_size) for g in GRASP_CLASSES]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _segment(skin, frames: np.ndarray, crop_size: int, chunk: int = 64):
    """Skin segmentation of test frames (N, H, W, 3), seeded at the frame centre (where the camera aims):
    (images (N, S, S), masks (N, S, S), found (N,)). `chunk` frames per call bounds the memory."""
    n, h, w, _ = frames.shape
    parts = []
    for i in range(0, n, chunk):
        part = frames[i: i + chunk]
        seg = hog_jax.segment(skin, part, seed_points=np.tile([h / 2.0, w / 2.0], (len(part), 1)),
                              out_size=crop_size)
        parts.append((np.asarray(seg.images), np.asarray(seg.masks), np.asarray(seg.found)))
    return tuple(np.concatenate([p[j] for p in parts]) for j in range(3))


def _features(images, masks, found, config: hog_jax.HOGConfig) -> np.ndarray:
    """HOG (N, D) of the found crops; rows of failed segmentations stay zero (never used)."""
    x = np.zeros((images.shape[0], hog_jax.hog_dim(config)), np.float32)
    ok = found & (images.reshape(len(images), -1).max(1) > 0)
    if ok.any():
        x[ok] = np.asarray(hog_jax.hog(images[ok], config, mask=masks[ok]))
    return x


def _predict(model, x, ok, k, **lsh):
    """Labels (N,) with -1 where segmentation failed, Euler (N, 3), quaternions (N, 4), neighbours."""
    labels = np.full(len(x), -1, np.int32)
    euler = np.full((len(x), 3), np.nan, np.float32)
    quat = np.full((len(x), 4), np.nan, np.float32)
    idx = np.full((len(x), k), -1, np.int32)
    dist = np.full((len(x), k), np.inf, np.float32)
    if ok.any():
        p = hog_jax.predict(model, x[ok], k=k, **lsh)
        labels[ok], euler[ok], quat[ok] = np.asarray(p.label), np.asarray(p.euler), np.asarray(p.quat)
        idx[ok], dist[ok] = np.asarray(p.indices), np.asarray(p.distances)
    return labels, euler, quat, idx, dist


def orientation_errors_deg(pred_euler, true_euler, pred_quat, true_quat) -> tuple[np.ndarray, np.ndarray]:
    """Absolute Euler-angle errors (N, 3) (azimuth and roll wrapped to [0, 180]) and the geodesic angle
    between the rotations (N,), in degrees."""
    d = np.degrees(np.asarray(pred_euler, float) - np.asarray(true_euler, float))
    d = np.abs((d + 180.0) % 360.0 - 180.0)
    dot = np.abs(np.sum(np.asarray(pred_quat, float) * np.asarray(true_quat, float), -1))
    return d, np.degrees(2.0 * np.arccos(np.clip(dot, 0.0, 1.0)))


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


def _timed(fn, repeats: int) -> float:
    """Median wall time (s) of `fn()` (its result blocked on) over `repeats`, after one warm-up call."""
    jax.block_until_ready(fn())
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def _accuracy(pred, true) -> float:
    return float(np.mean(np.asarray(pred) == np.asarray(true))) if len(true) else float("nan")


def _robot_accuracy(pred, true) -> dict:
    """Share of test images whose recognised grasp maps to the same robot preshape as the true one."""
    out = {}
    for mapping, hands in GRASP_MAPPINGS.items():
        for hand, table in hands.items():
            names = np.array([table[g] for g in GRASP_CLASSES] + ["none"])
            out[f"robot_grasp_accuracy_{mapping}_{hand}"] = float(np.mean(names[np.asarray(pred)] == names[true]))
    return out


def _sweeps(cfg: Config, db, tests: dict, seg: dict, k: int) -> dict:
    """Accuracy (exact kNN) against k, against the database grid and for every (B, L)."""
    base = hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=cfg.n_levels)
    out = {"k": {}, "db": {}, "bl": {}}

    def evaluate(db_, config, ks):
        model = hog_jax.fit(_features(db_.images, db_.masks, np.ones(len(db_.labels), bool), config),
                            db_.labels, db_.euler, n_classes=len(GRASP_CLASSES), seed=cfg.seed)
        res = {}
        for name, t in tests.items():
            x = _features(*seg[name], config)
            ok = seg[name][2]
            for kk in ks:
                res[(name, kk)] = _accuracy(_predict(model, x, ok, min(kk, len(db_.labels)))[0], t.labels)
        return res

    for (name, kk), acc in evaluate(db, base, cfg.k_values).items():
        out["k"].setdefault(name, {})[kk] = acc
    for g in progress(cfg.db_grids, desc="database sizes"):
        a, e = _grid(g)
        for (name, _), acc in evaluate(_database(cfg, a, e), base, (k,)).items():
            out["db"].setdefault(name, {})[a * e] = acc
    pairs = [(b, lv) for b in cfg.bins_sweep for lv in cfg.levels_sweep]
    for b, lv in progress(pairs, desc="B x L"):
        for (name, _), acc in evaluate(db, hog_jax.HOGConfig(n_bins=b, n_levels=lv), (k,)).items():
            out["bl"].setdefault(name, {})[(b, lv)] = acc
    return out


def _plot_confusions(run: RunOutput, mats: dict[str, np.ndarray], accs: dict[str, float]):
    fig, axes = plt.subplots(1, len(mats), figsize=(4.2 * len(mats), 4.2))
    ticks = [str(g) for g in GRASP_CLASSES]
    for ax, (name, c) in zip(np.atleast_1d(axes), mats.items()):
        rate = c / np.maximum(c.sum(1, keepdims=True), 1)
        ax.imshow(rate, cmap="gray", vmin=0, vmax=1)
        ax.set_xticks(range(len(ticks) + 1), ticks + ["none"])
        ax.set_yticks(range(len(ticks)), ticks)
        ax.set_xlabel("recognised")
        ax.set_ylabel("true")
        ax.set_title(f"{name}: {100 * accs[name]:.0f} % (n = {c.sum()})")
        for i in range(rate.shape[0]):
            for j in range(rate.shape[1]):
                if c[i, j]:
                    ax.text(j, i, str(c[i, j]), ha="center", va="center", color="red", fontsize=8)
    fig.suptitle("Confusion matrices (white = 100 %), like GRASP Fig. 7")
    run.save_figure(fig, "confusion.png")


def _plot_orientation(run: RunOutput, errs: dict[str, np.ndarray], geo: dict[str, float]):
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    width = 0.8 / (len(errs) + 1)
    xs = np.arange(3)
    ax.bar(xs, [0.0, 16.8, 10.5], width, label="paper, X (angles as printed)", color="0.6")
    for i, (name, e) in enumerate(errs.items()):
        ax.bar(xs + (i + 1) * width, e, width, label=f"ours, {name} (geodesic {geo[name]:.1f}°)")
    ax.set_xticks(xs + width * len(errs) / 2, ["azimuth φ", "elevation θ", "roll ψ"])
    ax.set_ylabel("mean absolute error (deg)")
    ax.set_title("Orientation error, like GRASP Fig. 8")
    ax.legend(fontsize=8)
    run.save_figure(fig, "orientation.png")


def _plot_neighbours(run: RunOutput, queries, db, idx, dist, true, labels, n_show: int = 7):
    n_show = min(n_show, idx.shape[1])
    fig, axes = plt.subplots(len(queries), n_show + 1, figsize=(1.6 * (n_show + 1), 1.9 * len(queries)))
    axes = np.atleast_2d(axes)
    for r, (img, q) in enumerate(queries):
        axes[r, 0].imshow(img, cmap="gray")
        axes[r, 0].set_title(f"query: {GRASP_CLASSES[true[q]]}\nrecognised {GRASP_CLASSES[labels[q]]}"
                             if labels[q] >= 0 else "query: no hand", fontsize=7)
        for c in range(n_show):
            ax = axes[r, c + 1]
            j = idx[q, c]
            if j >= 0:
                ax.imshow(db.images[j], cmap="gray")
                o = np.degrees(db.euler[j])
                ax.set_title(f"y={GRASP_CLASSES[db.labels[j]]} d={dist[q, c]:.2f}\n"
                             f"o=({o[0]:.0f},{o[1]:.0f},{o[2]:.0f})", fontsize=6)
        for ax in axes[r]:
            ax.axis("off")
    fig.suptitle("Nearest database views of test queries (class y, distance d, orientation o in deg), like Fig. 5",
                 fontsize=9)
    run.save_figure(fig, "neighbours.png")


def _plot_sweeps(run: RunOutput, sw: dict, cfg: Config):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for name, accs in sw["k"].items():
        axes[0].plot(list(accs), list(accs.values()), "o-", label=name)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("k")
    axes[0].set_ylabel("accuracy")
    axes[0].set_title("accuracy against k (exact kNN)")
    for name, accs in sw["db"].items():
        axes[1].plot(list(accs), list(accs.values()), "o-", label=name)
    axes[1].set_xscale("log")
    axes[1].set_xlabel("database views per grasp")
    axes[1].set_title("accuracy against database size")
    bl = sw["bl"]["large"]
    grid = np.array([[bl[(b, lv)] for lv in cfg.levels_sweep] for b in cfg.bins_sweep])
    im = axes[2].imshow(grid, cmap="viridis", vmin=0, vmax=1)
    axes[2].set_xticks(range(len(cfg.levels_sweep)), cfg.levels_sweep)
    axes[2].set_yticks(range(len(cfg.bins_sweep)), cfg.bins_sweep)
    axes[2].set_xlabel("levels L")
    axes[2].set_ylabel("bins B")
    axes[2].set_title("accuracy on the large set for B x L")
    for i in range(grid.shape[0]):
        for j in range(grid.shape[1]):
            axes[2].text(j, i, f"{grid[i, j]:.2f}", ha="center", va="center", color="w", fontsize=8)
    fig.colorbar(im, ax=axes[2])
    for ax in axes[:2]:
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    run.save_figure(fig, "sweeps.png")


def _plot_contact_sheet(run: RunOutput, db, X, seg_images, per_view: int):
    """Per grasp: three database views, the three snapshots of its first test sequence and their
    segmented crops."""
    n_cols = 9
    fig, axes = plt.subplots(len(GRASP_CLASSES), n_cols, figsize=(1.5 * n_cols, 1.6 * len(GRASP_CLASSES)))
    for gi, g in enumerate(GRASP_CLASSES):
        views = gi * per_view + np.linspace(0, per_view - 1, 5).astype(int)[1:4]
        seq = np.flatnonzero(X.labels == gi)[:3]
        panels = ([(db.images[v], "gray", f"db {g}") for v in views] + [(X.frames[i], None, STAGES[X.stage[i]])
                                                                        for i in seq]
                  + [(seg_images[i], "gray", "segmented") for i in seq])
        for c, (img, cmap, title) in enumerate(panels):
            axes[gi, c].imshow(img, cmap=cmap, vmin=0 if cmap else None, vmax=1 if cmap else None)
            axes[gi, c].set_title(title, fontsize=6)
        for ax in axes[gi]:
            ax.axis("off")
        axes[gi, 0].text(-0.3, 0.5, f"{g}\n{GRASP_NAMES[g]}", transform=axes[gi, 0].transAxes, ha="right",
                         va="center", fontsize=7)
    fig.suptitle("Database views (database hand), test frames (test hand) and their skin segmentation", fontsize=9)
    run.save_figure(fig, "contact_sheet.png")


def run_experiment(cfg: Config, run: RunOutput) -> tuple[dict, str, dict]:
    """The whole evaluation; writes figures into `run` and returns (flat metrics, report markdown,
    nested metrics: per-Euler-angle errors as lists, confusion matrices)."""
    t_start = time.perf_counter()
    hcfg = hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=cfg.n_levels)
    key = jax.random.key(cfg.seed)
    t0 = time.perf_counter()
    db = _database(cfg, cfg.n_azimuth, cfg.n_elevation)
    per_view = cfg.n_azimuth * cfg.n_elevation
    db_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    X = sequence_set(cfg.seed, cfg.frame_size, progress=_bar("render X"))
    large = random_set(cfg.n_large, cfg.seed, cfg.frame_size, progress=_bar("render large set"))
    skin_px, bg_px = skin_training_pixels(cfg.seed, cfg.n_skin_images)
    skin = hog_jax.fit_skin_model(jax.random.fold_in(key, 1), skin_px, bg_px)
    tests_s = time.perf_counter() - t0

    both = _segment(skin, np.concatenate([X.frames, large.frames]), cfg.crop_size)  # one worker for both
    seg = {"X": tuple(a[: len(X.labels)] for a in both), "large": tuple(a[len(X.labels):] for a in both)}
    tests = {"X": X, "large": large}
    db_x = _features(db.images, db.masks, np.ones(len(db.labels), bool), hcfg)
    model = hog_jax.fit(db_x, db.labels, db.euler, n_classes=len(GRASP_CLASSES), seed=cfg.seed)
    ho_img, ho_mask = _held_out(cfg)
    ho_x = _features(ho_img, ho_mask, np.ones(len(ho_img), bool), hcfg)
    tune = hog_jax.tune(jax.random.fold_in(key, 2), db_x, ho_x, k=cfg.k, target_recall=cfg.lsh_target_recall)
    index = hog_jax.build_index(jax.random.fold_in(key, 3), db_x, tune.n_bits, tune.n_tables)
    lsh = dict(index=index, n_per_table=tune.n_per_table, n_tables=tune.n_tables, max_rerank=tune.max_rerank)

    feats = {name: _features(*seg[name], hcfg) for name in tests}
    res, res_exact = {}, {}
    for name, t in tests.items():
        res[name] = _predict(model, feats[name], seg[name][2], cfg.k, **lsh)
        res_exact[name] = _predict(model, feats[name], seg[name][2], cfg.k)

    m: dict = {"n_database_views": len(db.labels), "n_views_per_grasp": per_view, "n_test_X": len(X.labels),
               "n_test_large": len(large.labels), "hog_dim": int(db_x.shape[1]), "knn_sigma": float(model.sigma)}
    mats, accs = {}, {}
    subsets = {**{k_: (X, res["X"], v) for k_, v in stage_subsets(X.stage).items()},
               "large": (large, res["large"], np.ones(len(large.labels), bool))}
    for name, (t, r, sel) in subsets.items():
        accs[name] = _accuracy(r[0][sel], t.labels[sel])
        mats[name] = confusion(t.labels[sel], r[0][sel], len(GRASP_CLASSES))
        m[f"accuracy_{name}"] = accs[name]
    for name, t in tests.items():
        found = seg[name][2]
        m[f"segmentation_found_rate_{name}"] = float(np.mean(found))
        m[f"accuracy_{name}_exact_knn"] = _accuracy(res_exact[name][0], t.labels)
        correct = int(np.sum(res[name][0] == t.labels))
        lo, hi = wilson_interval(correct, len(t.labels))
        m[f"accuracy_{name}_ci95_low"], m[f"accuracy_{name}_ci95_high"] = lo, hi
        m.update({f"{k_}_{name}": v for k_, v in _robot_accuracy(res[name][0], t.labels).items()})
    for s, sname in enumerate(("stage0", "stage1", "stage2")):
        sel = large.stage == s
        m[f"accuracy_large_{sname}"] = _accuracy(res["large"][0][sel], large.labels[sel])

    # orientation (eq. 4), over every test image with a hand found, and over the correctly classified ones
    errs, geo, nested = {}, {}, {}
    for name, t in tests.items():
        ok = seg[name][2]
        e, g = orientation_errors_deg(res[name][1][ok], t.euler[ok], res[name][2][ok], t.quat[ok])
        right = res[name][0][ok] == t.labels[ok]
        errs[name], geo[name] = e.mean(0), float(g.mean())
        nested[name] = [float(v) for v in e.mean(0)]
        for j, an in enumerate(_EULER_NAMES):
            m[f"orientation_error_deg_{an}_{name}"] = float(e[:, j].mean())
            m[f"orientation_error_deg_{an}_{name}_correct"] = float(e[right, j].mean()) if right.any() else float("nan")
        m[f"orientation_geodesic_error_deg_{name}"] = geo[name]
        m[f"orientation_geodesic_error_deg_{name}_correct"] = float(g[right].mean()) if right.any() else float("nan")
        m[f"orientation_geodesic_error_deg_{name}_median"] = float(np.median(g))

    # LSH against exact kNN: recall@k and query time on the large set
    q = feats["large"][seg["large"][2]]
    exact = hog_jax.exact_search(db_x, q, cfg.k)
    approx = hog_jax.query(index, q, cfg.k, tune.n_per_table, tune.n_tables, max_rerank=tune.max_rerank)
    m["lsh_recall_at_k"] = hog_jax.recall_at_k(approx.indices, exact.indices)
    m["lsh_recall_at_k_held_out"] = float(tune.recall)
    m["lsh_n_bits"], m["lsh_n_tables"], m["lsh_max_rerank"] = tune.n_bits, tune.n_tables, tune.max_rerank
    m["lsh_mean_scanned"] = float(np.mean(np.asarray(approx.n_scanned)))
    t_lsh = _timed(lambda: hog_jax.predict(model, q, cfg.k, **lsh).label, cfg.timing_repeats)
    t_exact = _timed(lambda: hog_jax.predict(model, q, cfg.k).label, cfg.timing_repeats)
    m["query_ms"] = 1e3 * t_lsh / len(q)
    m["query_ms_exact"] = 1e3 * t_exact / len(q)
    m["n_queries_timed"] = len(q)

    sw = _sweeps(cfg, db, tests, seg, cfg.k)
    for name, accs_k in sw["k"].items():
        m.update({f"accuracy_{name}_k{kk}": v for kk, v in accs_k.items()})
    for name, accs_d in sw["db"].items():
        m.update({f"accuracy_{name}_db{n}": v for n, v in accs_d.items()})
    for name, accs_bl in sw["bl"].items():
        m.update({f"accuracy_{name}_B{b}_L{lv}": v for (b, lv), v in accs_bl.items()})
        vals = np.array(list(accs_bl.values()))
        m[f"accuracy_{name}_BL_range"] = float(vals.max() - vals.min())
    m["time_database_s"], m["time_tests_s"] = db_s, tests_s
    m["time_total_s"] = time.perf_counter() - t_start

    _plot_confusions(run, mats, accs)
    _plot_orientation(run, errs, geo)
    picks = [i for i in np.flatnonzero(seg["X"][2])][:: max(1, int(seg["X"][2].sum()) // 4)][:4]
    _plot_neighbours(run, [(seg["X"][0][i], i) for i in picks], db, res["X"][3], res["X"][4], X.labels, res["X"][0])
    _plot_sweeps(run, sw, cfg)
    _plot_contact_sheet(run, db, X, seg["X"][0], per_view)
    nested_metrics = {"orientation_error_deg": nested["X"], "orientation_error_deg_large": nested["large"],
                      "orientation_geodesic_error_deg": geo["X"],
                      "confusion_X": mats["X"].tolist(), "confusion_large": mats["large"].tolist(),
                      "true_class_X": [GRASP_CLASSES[i] for i in X.labels],
                      "recognised_class_X": [GRASP_CLASSES[i] if i >= 0 else -1 for i in res["X"][0]],
                      "stage_X": X.stage.tolist()}
    return m, _report(cfg, m, nested_metrics, mats), nested_metrics


def _report(cfg: Config, m: dict, nested: dict, mats: dict) -> str:
    e = nested["orientation_error_deg"]
    rows = [
        ("X (36)", f"{100 * m['accuracy_X']:.0f} %", "61 % (human 74 %)"),
        ("X' (24)", f"{100 * m['accuracy_Xp']:.0f} %", "71 %"),
        ("X'' (12)", f"{100 * m['accuracy_Xpp']:.0f} %", "75 %"),
        (f"large ({m['n_test_large']})", f"{100 * m['accuracy_large']:.1f} % "
         f"[{100 * m['accuracy_large_ci95_low']:.1f}, {100 * m['accuracy_large_ci95_high']:.1f}]", "-"),
        ("orientation error, X (az, el, roll)", f"({e[0]:.1f}, {e[1]:.1f}, {e[2]:.1f}) deg", "(0, 16.8, 10.5) deg"),
        ("geodesic orientation error, X / large", f"{m['orientation_geodesic_error_deg_X']:.1f} / "
         f"{m['orientation_geodesic_error_deg_large']:.1f} deg", "-"),
        ("LSH recall@k (large set) / held-out", f"{m['lsh_recall_at_k']:.3f} / {m['lsh_recall_at_k_held_out']:.3f}",
         "ε = 0.05"),
        ("accuracy LSH / exact kNN (large)", f"{m['accuracy_large']:.3f} / {m['accuracy_large_exact_knn']:.3f}", "-"),
        ("query time LSH / exact", f"{m['query_ms']:.3f} / {m['query_ms_exact']:.3f} ms", "-"),
        ("hand found by skin segmentation, X / large", f"{100 * m['segmentation_found_rate_X']:.0f} % / "
         f"{100 * m['segmentation_found_rate_large']:.0f} %", "-"),
    ]
    stage_rows = [(STAGES[s], f"{m[f'accuracy_large_stage{s}']:.3f}") for s in range(3)]
    robot = [(k_.replace("robot_grasp_accuracy_", ""), f"{v:.3f}") for k_, v in m.items()
             if k_.startswith("robot_grasp_accuracy_")]
    bl = [(k_.replace("accuracy_large_", ""), f"{v:.3f}") for k_, v in m.items()
          if k_.startswith("accuracy_large_B")]
    dbs = [(k_.replace("accuracy_", ""), f"{v:.3f}") for k_, v in m.items() if "_db" in k_ and k_.startswith("accuracy_")]
    ks = [(k_.replace("accuracy_", ""), f"{v:.3f}") for k_, v in m.items()
          if k_.startswith("accuracy_") and "_k" in k_ and "knn" not in k_]
    return f"""# Grasp recognition from one image (GRASP, IROS 2008)

Database: {m['n_database_views']} rendered views ({m['n_views_per_grasp']} per grasp, {cfg.n_azimuth} azimuths x
{cfg.n_elevation} elevations), HOG B = {cfg.n_bins}, L = {cfg.n_levels} (D = {m['hog_dim']}), LSH (K = {m['lsh_n_bits']},
T = {m['lsh_n_tables']}) + distance-weighted kNN, k = {cfg.k}, σ = {m['knn_sigma']:.3f} (eq. 5). Test hand: a different
MuJoCo hand (longer thinner fingers, wider flatter palm, darker skin), finger joints perturbed by up to ±15°,
random lighting, cluttered coloured background, noise and blur, segmented by the skin model.
Run time {m['time_total_s']:.0f} s (database {m['time_database_s']:.0f} s, test sets {m['time_tests_s']:.0f} s, cached
renders load in seconds).

{markdown_table(("", "ours", "paper"), rows)}

Accuracy on the large set by reach stage (X-like):

{markdown_table(("stage", "accuracy"), stage_rows)}

Recognised grasp mapped to a robot preshape (GRASP Fig. 2, MAP Fig. 2): share of images whose preshape is right

{markdown_table(("mapping / hand / set", "accuracy"), robot)}

Sensitivity (exact kNN): against k

{markdown_table(("set, k", "accuracy"), ks)}

against database size (views per grasp)

{markdown_table(("set, size", "accuracy"), dbs)}

for B x L (paper: "quite insensitive" for B in [3, 8], L in [2, 5]); range on the large set
{m['accuracy_large_BL_range']:.3f}

{markdown_table(("B, L", "accuracy (large)"), bl)}

Confusion matrix of the large set (rows true {list(GRASP_CLASSES)}, columns recognised, last = no hand found):

```
{np.array2string(mats['large'])}
```

## How this differs from the paper, and why
- **Test images are rendered, not real.** The paper tested on real camera images of a real hand; we render a
  different hand model with perturbed postures, other lighting, clutter, noise and blur. The gap between
  database and test is therefore a controlled one (proportions, tone, posture noise, lighting), not the
  appearance gap between Poser and a real hand; results are not directly comparable.
- **X, X', X'' are tiny** (36, 24, 12 images as in the paper): one image is 3 to 8 points. The large
  random set gives the figure with a confidence interval.
- **Orientation**: our three angles are the camera's azimuth, elevation (both varied over the half-sphere)
  and roll (always 0, like the paper's first angle, which is 0 in Fig. 8 for the same reason: the database
  has no in-plane rotation of the camera). Symmetric hand-object views (e.g. the ball from above) make
  azimuth ambiguous, which dominates the azimuth error.
- **LSH**: hyperplane LSH tuned to recall@k >= {cfg.lsh_target_recall} on held-out database-like views, with
  exact re-ranking of the candidates, instead of the paper's ε = 0.05 E2LSH; sweeps use exact kNN.
- **Skin model**: fitted on rendered hands of three other skin tones and clutter of another seed (the paper
  used a model trained on real skin); frames with no skin found count as errors.
"""


def demo_stage(cfg, run: RunOutput) -> tuple[dict, str]:
    """Demo stage: the `quick` evaluation (seeded by the demo's seed) in `run.path/grasp_recognition`, and
    the robot preshape each completed test grasp maps to (GRASP Fig. 2, MAP Fig. 2)."""
    sub = RunOutput(run.path / "grasp_recognition", "grasp_recognition")
    config = dataclasses.replace(Config(**PRESETS["quick"]), seed=cfg.seed)
    m, _, nested = run_experiment(config, sub)
    rows = []
    for true, got, stage in zip(nested["true_class_X"], nested["recognised_class_X"], nested["stage_X"]):
        if stage == 2:
            robot = lambda g, hand, mp="map2009": robot_grasp_for(g, hand, mp) if g > 0 else "-"
            rows.append((f"{true} {GRASP_NAMES[true]}", f"{got} {GRASP_NAMES.get(got, 'no hand')}",
                         robot(got, "barrett"), robot(got, "karlsruhe"), robot(got, "barrett", "iros2008")))
    keys = ("accuracy_X", "accuracy_Xp", "accuracy_Xpp", "accuracy_large", "orientation_geodesic_error_deg_X",
            "lsh_recall_at_k", "query_ms")
    section = (f"Grasp recognition (quick: {m['n_database_views']} database views): accuracy X / X' / X'' = "
               f"{100 * m['accuracy_X']:.0f} / {100 * m['accuracy_Xp']:.0f} / {100 * m['accuracy_Xpp']:.0f} % "
               f"(paper 61 / 71 / 75 %), large set {100 * m['accuracy_large']:.0f} %. Completed grasps of X and "
               "the robot preshape the recognised grasp maps to:\n\n"
               + markdown_table(("true", "recognised", "Barrett (MAP)", "Karlsruhe (MAP)", "Barrett (GRASP)"), rows))
    return {f"grasp_{k}": m[k] for k in keys}, section


def main(argv=None) -> dict:
    cfg, run = parse_config(Config, PRESETS, "grasp_recognition", argv)
    enable_compilation_cache()
    m, report, nested = run_experiment(cfg, run)
    run.write_metrics(m)
    # the nested metrics the issue asks for (lists) beside the flat ones
    run.write_json("metrics.json", {**json.loads(run.file("metrics.json").read_text()), **nested})
    run.write_report(report)
    print(report)
    return m


if __name__ == "__main__":
    main()
