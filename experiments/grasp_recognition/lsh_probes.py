"""Multi-probe LSH settings of the best preset, chosen on validation images only.

    python -m experiments.grasp_recognition.lsh_probes

The best preset's database and metric; its query-like validation images (own seed, own hand, every
nuisance, the adapted skin model) split in halves: `hog_jax.tune` picks (K, T) on the first half for each
probe count and target recall, and the index is measured on the second half: recall@k against exact
search and query time (median of 5, the half's queries in one batch), beside exact search. Then the
latency of one image at a time (`hog_jax.predict` on a single (D,) query, as a live camera would ask:
neighbours, vote and orientation), median over `N_SINGLE` held-out queries, for the best preset's index
(4 probes, target 0.9) and for exact search.
"""
from __future__ import annotations

import jax
import numpy as np

import hog_jax
import sim
from experiments.timing import time_call
from experiments.data.grasp_tests import skin_training_pixels
from experiments.grasp_recognition.config import PRESETS, Config
from experiments.grasp_recognition.recogniser import recogniser_of, study_database
from experiments.grasp_recognition.stages import validation_crops
from lfd_common import enable_compilation_cache
from lfd_jax.grasp import features

N_SINGLE = 200  # held-out queries timed one at a time


def main() -> None:
    sim.setup_rendering()
    enable_compilation_cache()
    cfg = Config(**PRESETS["best"])
    skin = hog_jax.fit_skin_model(jax.random.fold_in(jax.random.key(cfg.seed), 1),
                                  *skin_training_pixels(cfg.seed, cfg.n_skin_images))
    val = validation_crops(cfg, skin)
    rec = recogniser_of(cfg, jax.random.key(cfg.seed), study_database(cfg), None, skin)
    q = features(rec, val.images, val.masks, val.found)[val.found]
    half = len(q) // 2
    held_out = q[half:]
    exact = hog_jax.exact_search(rec.model.data, held_out, cfg.k)
    for probes in (0, 2, 4, 8):
        for target in (0.8, 0.9):
            t = hog_jax.tune(jax.random.key(2), rec.model.data, q[:half], k=cfg.k,
                             options=hog_jax.TuneOptions(target_recall=target, n_probes=probes))
            index = hog_jax.build_index(jax.random.key(3), rec.model.data, t.n_bits, t.n_tables)
            run = lambda: hog_jax.query(index, held_out, cfg.k, t.n_per_table, t.n_tables, t.max_rerank, probes)
            recall = hog_jax.recall_at_k(np.asarray(run().indices), np.asarray(exact.indices))
            ms = 1e3 * time_call(lambda: run().indices, 5).median_s / len(held_out)
            print(f"probes {probes} target {target}: K {t.n_bits} T {t.n_tables} R {t.max_rerank} tuning recall "
                  f"{t.recall:.3f} held-out recall {recall:.3f} scanned {t.mean_scanned:.0f} query {ms:.3f} ms",
                  flush=True)
            if (probes, target) == (4, 0.9):  # the best preset's setting, timed one image at a time below
                lsh = {"index": index, "n_per_table": t.n_per_table, "n_tables": t.n_tables,
                       "max_rerank": t.max_rerank, "n_probes": probes}
    ms = 1e3 * time_call(lambda: hog_jax.exact_search(rec.model.data, held_out, cfg.k).indices, 5).median_s
    print(f"exact search: {ms / len(held_out):.3f} ms per query")
    singles = held_out[:N_SINGLE]
    for name, kwargs in (("LSH, 4 probes", lsh), ("exact", {})):
        times = [time_call(lambda x=x: hog_jax.predict(rec.model, x, cfg.k, **kwargs).label, 3).median_s
                 for x in singles]
        print(f"one image at a time, {name}: median {1e3 * np.median(times):.3f} ms, 90th percentile "
              f"{1e3 * np.percentile(times, 90):.3f} ms ({len(singles)} queries)", flush=True)


if __name__ == "__main__":
    main()
