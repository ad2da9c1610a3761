"""Generating (and caching) the data set, and the images of one recording."""
from __future__ import annotations

import numpy as np

import sim
from experiments.data.oac.settings import N_CLASSES, OACData, OACSettings, VERSION, draw_persons
from experiments.data.oac.views import Views, masked_hog, record
from lfd_common import Cache, check_int


# Keyed by every setting and the source the generator runs (`views` takes HOG from `hog_jax`, `motion`
# the stereo model from `hog_jax.video`), so a change to the simulation never reuses stale renders.
_DATA = Cache("oac", packages=("experiments.data.oac", "sim", "hog_jax", "lfd_common"), version=VERSION)


def generate(settings: OACSettings = OACSettings(), cache: bool = True, progress=None) -> OACData:
    """Simulate the OAC data set: every class x person x repetition (N = 3 * persons * repetitions).

    Deterministic from `settings.seed`; cached under `cache_dir("oac")` keyed by every setting and the
    source it runs; `cache=False` simulates without reading or writing.
    `progress`: optional wrapper of an iterable (e.g. `experiments.config.progress`) for a progress bar.
    """
    if not isinstance(settings, OACSettings):
        raise ValueError(f"settings: expected an OACSettings, got {type(settings).__name__}")
    sim.setup_rendering()
    return _DATA.get(lambda: _simulate(settings, progress), enabled=cache, settings=settings)


def _simulate(settings: OACSettings, progress) -> OACData:
    """The data set of `generate`, simulated (uncached)."""
    rng = np.random.default_rng(settings.seed)
    persons = draw_persons(rng, settings.n_persons)
    jobs = [(c, p) for p in range(settings.n_persons) for c in range(N_CLASSES)]
    recs, meta = [], []
    for c, p in (progress(jobs, desc="rendering OAC recordings") if progress else jobs):
        views = Views(c, persons[p], settings.image_px)
        for r in range(settings.n_repetitions):
            sub = np.random.default_rng([settings.seed, c, p, r])
            recs.append(record(views, c, persons[p], sub, settings))
            meta.append((c, p, r))
        views.close()
    lengths = np.array([r["n"] for r in recs])
    hand_hog = masked_hog(np.concatenate([r["hand_img"] for r in recs]), np.concatenate([r["hand_mask"] for r in recs]),
                          settings.n_bins, settings.hand_levels)
    obj_hog = masked_hog(np.concatenate([r["obj_img"] for r in recs]), np.concatenate([r["obj_mask"] for r in recs]),
                         settings.n_bins, settings.object_levels)
    starts = np.concatenate([[0], np.cumsum(lengths)])
    n, t_max = len(recs), int(lengths.max())

    def pad(rows):
        out = np.zeros((n, t_max) + rows[0].shape[1:], np.float32)
        for i, row in enumerate(rows):
            out[i, : len(row)] = row
        return out

    meta = np.array(meta)
    return OACData(
        action=meta[:, 0], object=meta[:, 0].copy(), person=meta[:, 1], repetition=meta[:, 2], lengths=lengths,
        pos2d=pad([r["pos2d"] for r in recs]), pos3d=pad([r["pos3d"] for r in recs]),
        hand_hog=pad([hand_hog[starts[i]:starts[i + 1]] for i in range(n)]),
        object_hog=pad([obj_hog[starts[i]:starts[i + 1]] for i in range(n)]),
        hand_true=pad([r["hand_true"] for r in recs]),
    )


def recording_images(settings: OACSettings, cls: int, person: int, repetition: int) -> dict:
    """Re-render one recording of `generate(settings)` (same seeds) and return its images and masks:
    hand_img / hand_mask (T, P, P), obj_img / obj_mask (T, S, S), pos2d (T, 2), pos3d (T, 3), n."""
    cls = check_int(cls, "cls", min_value=0, max_value=N_CLASSES - 1)
    person = check_int(person, "person", min_value=0, max_value=settings.n_persons - 1)
    repetition = check_int(repetition, "repetition", min_value=0, max_value=settings.n_repetitions - 1)
    sim.setup_rendering()
    persons = draw_persons(np.random.default_rng(settings.seed), settings.n_persons)
    views = Views(cls, persons[person], settings.image_px)
    try:
        return record(views, cls, persons[person], np.random.default_rng([settings.seed, cls, person, repetition]),
                      settings)
    finally:
        views.close()
