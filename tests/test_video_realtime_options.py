"""`VideoOptions.real_video()`'s level sets for real time: the fine scale's iterations after the coarse
one capped, every other level-set option the default's, and a caller's level-set options still winning."""
import numpy as np

import hog_jax.video as hv


def test_real_video_caps_the_fine_scale_only():
    real = hv.VideoOptions.real_video().levelset
    cap = real.fine_it_max
    assert isinstance(cap, int) and 1 <= cap < real.it_max
    assert real._replace(fine_it_max=None) == hv.VideoOptions().levelset
    # a noisy square whose fine contour keeps changing by more than the tolerance: the default runs past
    # the cap, real_video's stops at it; the coarse scale is the same in both
    rng = np.random.default_rng(0)
    labels = np.zeros((32, 32), int)
    labels[8:24, 10:26] = 1
    scores = np.where(np.arange(2)[:, None, None] == labels, 0.0, -2.0) + rng.normal(0, 3.0, (3, 2, 32, 32))
    structure = hv.LevelSetStructure(2, (32, 32), (16, 16))
    free = hv.segment_video(structure, scores.astype(np.float32), options=hv.VideoOptions().levelset)
    capped = hv.segment_video(structure, scores.astype(np.float32), options=real)
    assert np.asarray(free.iterations).max() > cap
    assert np.asarray(capped.iterations).max() == cap
    assert int(capped.iterations_coarse[0]) == int(free.iterations_coarse[0])
    assert hv.VideoOptions.real_video(levelset=hv.LevelSetOptions()).levelset.fine_it_max is None
