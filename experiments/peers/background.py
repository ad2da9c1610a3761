"""The background-subtraction peers, OpenCV's MOG2 and KNN, beside ours on the same frames, scored by
CDnet's convention (`experiments.data.cdnet.score_cdnet`): shared by the background benchmark and the
video segmentation study."""
from __future__ import annotations

import numpy as np

from experiments.data.cdnet import score_cdnet

FIRST_SCORED_FRAME = 470  # CDnet highway: frames 1-469 are unlabelled learning frames


def opencv_masks(frames_rgb: np.ndarray, make, learning_rate: float = -1.0) -> np.ndarray:
    """Foreground (T, H, W) bool of an OpenCV subtractor (`make()` builds it) applied frame by frame
    (BGR input as OpenCV expects; 255 = foreground, 127 = shadow = background)."""
    sub = make()
    out = np.empty(frames_rgb.shape[:3], bool)
    for t, frame in enumerate(frames_rgb):
        out[t] = sub.apply(np.ascontiguousarray(frame[..., ::-1]), learningRate=learning_rate) == 255
    return out


def _score(name: str, fg, labels, roi, first: int) -> dict:
    s = score_cdnet(np.asarray(fg)[first - 1:], labels[first - 1:], roi)
    print(f"{name:28s} precision {s.precision:.3f} recall {s.recall:.3f} F1 {s.f1:.3f}", flush=True)
    return {"precision": s.precision, "recall": s.recall, "f1": s.f1}


def f1_stage(frames, labels, roi, eval_first: int = FIRST_SCORED_FRAME, ablations: bool = False) -> dict:
    """Precision, recall and F1 of every model on frames `eval_first`.. (1-based) of `frames` (the
    module docstring of `experiments.bench.bench_background` says what each model is)."""
    import cv2

    from hog_jax import median3
    from hog_jax.video import BackgroundOptions, run_background

    def ours(**options):
        return lambda: run_background(frames, options=BackgroundOptions(**options))[1]

    def opencv(make, rate=-1.0):
        return lambda: opencv_masks(frames, make, rate)

    def filtered(masks):  # GRASP's 3 x 3 median filter, three times (`hog_jax.median3`), frame by frame
        return lambda: np.concatenate([np.asarray(median3(c, 3)) for c in np.array_split(masks(), 16)])

    mog2, knn = cv2.createBackgroundSubtractorMOG2, cv2.createBackgroundSubtractorKNN
    runs = {"ours": ours(), "ours_matched_rule": ours(decision="matched"), "mog2": opencv(mog2),
            "mog2_alpha": opencv(mog2, BackgroundOptions().alpha), "knn": opencv(knn)}
    if ablations:
        rate = 1.0 / 500  # MOG2's long-run learning rate: 1 / its default history
        runs.update({
            "ablation_rho_alpha_eta": ours(rho="alpha_eta"),
            "ablation_no_variance_floor": ours(min_variance=1e-6),
            "ablation_alpha_mog2_rate": ours(alpha=rate),
            "ablation_alpha_mog2_rate_matched_rule": ours(alpha=rate, decision="matched"),
            "ablation_median3_ours": filtered(ours()),
            "ablation_median3_ours_alpha_mog2_rate": filtered(ours(alpha=rate)),
            "ablation_median3_mog2": filtered(opencv(mog2)),
        })
    return {name: _score(name, masks(), labels, roi, eval_first) for name, masks in runs.items()}
