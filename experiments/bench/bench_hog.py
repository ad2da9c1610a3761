"""HOG throughput: hog_jax.hog against scikit-image's `hog`, same images, same dtype, same machine.

    python -m experiments.bench.bench_hog --preset quick --out runs/bench_hog

Images: procedural hand images (experiments.data.hog_features.hand_images), float32 in [0, 1],
B images of S x S for S in `sizes`. Two configurations, each timed end to end from the numpy batch
(float32) to the features on the host side of each library (ours: validation + device transfer +
jitted computation, `jax.block_until_ready`; compile time measured apart):

* ``cells`` (where the two coincide; the ratio `ratio_vs_skimage_<S>`): one level of 4 x 4 cells,
  n_bins orientations, magnitude-weighted hard bins, each cell L1-normalised. scikit-image:
  `hog(img, orientations=n_bins, pixels_per_cell=(S/4, S/4), cells_per_block=(1, 1), block_norm="L1")`.
  (scikit-image measures the angle from the column axis, eq. 1 from the row axis: the same work,
  features equal up to a transpose; tests/test_hog_features.py checks the agreement.)
* ``pyramid`` (GRASP: n_bins = 4, L = 3, global normalisation): scikit-image has no pyramid, so its
  closest path is one call per level (pixels per cell S/4, S/2, S; cells_per_block (1, 1)) with
  the histograms concatenated and divided by their total. `ratio_pyramid_vs_skimage_<S>`.

scikit-image is timed as a plain loop (its documented use: one image per call) and, to give it the
machine's cores as XLA has them, over a warm `multiprocessing` pool with one process per core
(`ratio_vs_skimage_pool_<S>`). Timings: warm-up on both sides, median of `repeats`.
"""
from __future__ import annotations

import dataclasses
import multiprocessing as mp
import os

import numpy as np

from experiments.timing import time_call
from experiments.config import markdown_table, parse_config
from lfd_common import enable_compilation_cache


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """HOG: hog_jax vs scikit-image on a batch of procedural hand images."""

    seed: int = 0
    n_images: int = 5400
    sizes: tuple[int, ...] = (64, 128)
    n_bins: int = 4
    repeats: int = 3
    pool: bool = True

    def __post_init__(self):
        if self.n_images < 1 or self.repeats < 1 or not self.sizes or min(self.sizes) < 4:
            raise ValueError("n_images and repeats must be positive, sizes at least 4")


PRESETS = {"quick": {"n_images": 600, "repeats": 2}, "paper": {}}


def _sk_cells(imgs, n_bins):
    from skimage.feature import hog as skhog
    S = imgs.shape[1]
    return np.stack([skhog(im, orientations=n_bins, pixels_per_cell=(S // 4, S // 4), cells_per_block=(1, 1),
                           block_norm="L1") for im in imgs])


def _sk_pyramid_calls(imgs, n_bins):
    """One skimage call per level (4 x 4, 2 x 2, 1 x 1 cells), concatenated. skimage does not expose
    raw cell sums (with 1 x 1 blocks each cell is L1-normalised), so GRASP's global normalisation
    cannot be reproduced exactly; each level is divided by its number of cells instead (the same work,
    values differ from ours)."""
    from skimage.feature import hog as skhog
    S = imgs.shape[1]
    out = np.empty((imgs.shape[0], n_bins * 21), np.float64)
    for i, im in enumerate(imgs):
        parts = [skhog(im, orientations=n_bins, pixels_per_cell=(S // n, S // n), cells_per_block=(1, 1),
                       block_norm="L1") / (n * n) for n in (4, 2, 1)]
        out[i] = np.concatenate(parts)
    return out


def _pool_map(pool, fn, imgs, n_bins, n_proc):
    chunks = np.array_split(imgs, n_proc * 4)
    return np.concatenate(pool.starmap(fn, [(c, n_bins) for c in chunks]))


def time_size(cfg: BenchConfig, imgs, hcfg, skfn, pool, n_proc: int) -> dict:
    """One configuration at one image size: ours from numpy and from device input, scikit-image as a
    loop and over the process pool."""
    import jax

    import hog_jax

    ours = time_call(lambda: hog_jax.hog(imgs, hcfg), cfg.repeats)
    dev = jax.device_put(imgs)
    on_device = time_call(lambda: hog_jax.hog(dev, hcfg), cfg.repeats)
    sk = time_call(lambda: skfn(imgs, cfg.n_bins), cfg.repeats, warmup=lambda: skfn(imgs[:8], cfg.n_bins),
                   block=False)
    t_pool = float("nan")
    if pool is not None:
        t_pool = time_call(lambda: _pool_map(pool, skfn, imgs, cfg.n_bins, n_proc), cfg.repeats, block=False,
                           warmup=lambda: _pool_map(pool, skfn, imgs[: 8 * n_proc], cfg.n_bins, n_proc)).median_s
    B, t_ours = cfg.n_images, ours.median_s
    return {
        "ours_images_per_s": B / t_ours, "ours_device_input_images_per_s": B / on_device.median_s,
        "skimage_images_per_s": B / sk.median_s, "skimage_pool_images_per_s": B / t_pool,
        "ratio": sk.median_s / t_ours, "ratio_pool": t_pool / t_ours, "compile_s": ours.compile_s,
    }


ROW_KEYS = ("ours_images_per_s", "ours_device_input_images_per_s", "skimage_images_per_s",
            "skimage_pool_images_per_s", "ratio", "ratio_pool", "compile_s")


def throughput_stage(cfg: BenchConfig, n_proc: int) -> tuple[dict, list]:
    """Both configurations at every image size, scikit-image's pool kept warm throughout: (results by
    "<config>_<S>", table rows)."""
    import hog_jax
    from experiments.data.hog_features import hand_images

    configs = {
        "cells": (hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=4, layout="grid", normalize="cell"), _sk_cells),
        "pyramid": (hog_jax.HOGConfig(n_bins=cfg.n_bins, n_levels=3), _sk_pyramid_calls),
    }
    results, rows = {}, []
    pool = mp.get_context("spawn").Pool(n_proc) if cfg.pool else None
    try:
        for S in cfg.sizes:
            imgs, _, _ = hand_images(cfg.n_images, seed=cfg.seed, size=S)
            imgs = np.ascontiguousarray(imgs, np.float32)
            for name, (hcfg, skfn) in configs.items():
                r = results[f"{name}_{S}"] = time_size(cfg, imgs, hcfg, skfn, pool, n_proc)
                rows.append([name, S, *(r[k] for k in ROW_KEYS)])
                print(f"{name:8s} S={S:4d}: ours {r['ours_images_per_s']:9.0f} img/s "
                      f"(device input {r['ours_device_input_images_per_s']:9.0f}), skimage {r['skimage_images_per_s']:7.0f} "
                      f"(pool of {n_proc}: {r['skimage_pool_images_per_s']:7.0f}); ratio {r['ratio']:.1f}x "
                      f"(vs pool {r['ratio_pool']:.1f}x); compile {r['compile_s']:.2f} s", flush=True)
    finally:
        if pool is not None:
            pool.close()
            pool.join()
    return results, rows


def main(argv=None):
    enable_compilation_cache()
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_hog", argv=argv)
    import jax

    n_proc = os.cpu_count() or 1
    results, rows = throughput_stage(cfg, n_proc)
    out = {"n_images": cfg.n_images, "n_bins": cfg.n_bins, "cpu_count": n_proc, "device": str(jax.devices()[0]),
           "results": results}
    for S in cfg.sizes:
        out[f"ratio_vs_skimage_{S}"] = results[f"cells_{S}"]["ratio"]
        out[f"ratio_vs_skimage_pool_{S}"] = results[f"cells_{S}"]["ratio_pool"]
        out[f"ratio_pyramid_vs_skimage_{S}"] = results[f"pyramid_{S}"]["ratio"]
    table = markdown_table(["config", "S", "ours img/s", "ours (device input)", "skimage img/s", "skimage pool",
                            "ratio", "ratio vs pool", "compile s"], rows)
    run.write(out, "# HOG benchmark\n\n" + table, filename="bench.json", flat=False)
    print("\n".join(f"{k} = {v:.2f}" for k, v in out.items() if k.startswith("ratio")))
    print(f"wrote {run.file('bench.json')}")


if __name__ == "__main__":
    main()
