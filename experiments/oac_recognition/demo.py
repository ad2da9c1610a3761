"""Demo stage "oac" of `experiments.demo`: one simulated OAC classified by a CHCRF trained on tiny data."""
from __future__ import annotations

import time

import numpy as np

import crf_jax
from experiments.config import StageResult, markdown_table
from experiments.data import oac
from experiments.data.oac_protocol import feature_sets, labels_per_frame, standardise
from experiments.plotting import plt


def demo_stage(cfg) -> StageResult:
    """`make demo` stage: classify one simulated OAC with a CHCRF trained on tiny data (< 30 s warm).

    cfg: the demo's config (only `cfg.seed` is used). Trains connectivity-0 action and object CRFs on
    two persons x 1 repetition (6 recordings, 4 frames/s), classifies a recording of a third person
    and returns its P(a, o | x) and normaliser Z(x) (eq. 8 / LfD eq. 9).
    """
    start = time.perf_counter()
    settings = oac.OACSettings(seed=int(cfg.seed), n_persons=3, n_repetitions=1, fps=4.0, image_px=32)
    data = oac.generate(settings)
    feats = feature_sets(data)
    train = data.person < 2
    test = int(np.flatnonzero((data.person == 2) & (data.action == int(cfg.seed) % oac.N_CLASSES))[0])
    lens = data.lengths
    log_p = {}
    for target, key, y in (("action", "action2d", data.action), ("object", "object", data.object)):
        X = standardise(feats[key], lens, train)
        model, _ = crf_jax.fit_chain(X[train], labels_per_frame(y[train], X.shape[1]), lens[train],
                                     n_labels=oac.N_CLASSES, l2=1.0, options=crf_jax.FitOptions(max_iter=40))
        log_p[target] = np.asarray(crf_jax.segment_log_probs(model, X[test:test + 1], lens[test:test + 1]))
    cooc = crf_jax.cooccurrence(data.action[train], data.object[train], oac.N_CLASSES, oac.N_CLASSES, smoothing=0.01)
    fused = crf_jax.fuse(log_p["action"], log_p["object"], cooc)
    joint = np.exp(np.asarray(fused.log_joint[0]))
    a, o = np.unravel_index(int(joint.argmax()), joint.shape)
    elapsed = time.perf_counter() - start
    fig, ax = plt.subplots(figsize=(4.2, 3.4))
    ax.imshow(joint, cmap="viridis", vmin=0, vmax=1)
    ax.set_xticks(range(3), oac.OBJECTS)
    ax.set_yticks(range(3), oac.ACTIONS)
    for i in range(3):
        for j in range(3):
            ax.text(j, i, f"{joint[i, j]:.2f}", ha="center", va="center", color="w" if joint[i, j] < 0.5 else "k")
    ax.set_title(f"P(a, o | x), truth: {oac.CLASSES[data.action[test]]}", fontsize=8)
    truth = int(data.action[test])
    metrics = {"oac_demo_true_class": oac.CLASSES[truth], "oac_demo_action": oac.ACTIONS[a],
               "oac_demo_object": oac.OBJECTS[o], "oac_demo_correct": bool(a == truth and o == truth),
               "oac_demo_p_joint": float(joint[a, o]), "oac_demo_log_z": float(fused.log_z[0]),
               "oac_demo_frames": int(lens[test]), "oac_demo_s": elapsed}
    report = "\n".join([
        "## Stage oac: simultaneous action-object recognition (CHCRF)", "",
        f"One simulated recording ({int(lens[test])} frames of rendered hand and object views, person 2) "
        f"classified by connectivity-0 CRFs trained on {int(train.sum())} recordings of two other persons, "
        "fused with the co-occurrence of the training labels (ECCV 2008 eq. 8).", "",
        markdown_table(["quantity", "value"], [
            ("truth", oac.CLASSES[truth]), ("CHCRF", f"{oac.ACTIONS[a]} {oac.OBJECTS[o]}"),
            ("P(a, o \\| x)", float(joint[a, o])), ("log Z(x)", float(fused.log_z[0])), ("time (s)", elapsed)]),
        "", "![oac](oac_demo.png)",
    ])
    return StageResult(metrics, {"oac_demo.png": fig}, report)
