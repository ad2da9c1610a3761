"""Figures of the learning-from-demonstration study: LfD 2009 Fig. 3 (the likelihood-ratio maps of one
frame), the object masks of held frames side by side, and Fig. 8 (raw, filtered and true "object in hand"
over a long recording)."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from experiments.peers.object_peer import window  # noqa: E402
from experiments.data.video.settings import ACTIONS, OBJECTS  # noqa: E402


def _shown_frame(first) -> int:
    """The frame of Fig. 3: the held-object frame (hand moved, object found) where our mask overlaps the
    truth most; else the held-object frame with the most true object pixels in the window."""
    truth = first["truth"].sum(axis=(1, 2))
    overlap = (first["masks"] & first["truth"]).sum(axis=(1, 2)) * first["decided"]
    return max(int(np.argmax(overlap)) if overlap.max() > 0 else int(np.argmax(truth)), 1)  # cues start at frame 1


def likelihood_ratios(first) -> plt.Figure:
    """Fig. 3 b-j for one frame of the first long recording (`_shown_frame`: our best-overlapping one,
    so the figure shows the method at its best, not a typical frame): the window, log r_m (temporal),
    log r_s (stereo), their sum, our mask and the true held object."""
    t = _shown_frame(first)
    seg, half = first["objects"], first["half"]
    centre = np.asarray(first["hand"])[t]
    temporal = np.asarray(seg.temporal.log_ratio)[t - 1]
    stereo = np.asarray(seg.stereo.log_ratio)[t - 1]
    joint = temporal + stereo
    panels = [("left window", window(first["grey"][t], centre, half), "gray"),
              ("log r_m (temporal, eq. 1)", temporal, "RdBu_r"),
              ("log r_s (stereo, eqs. 3-4)", stereo, "RdBu_r"), ("log r_m + log r_s", joint, "RdBu_r"),
              ("our mask (Fig. 3j)", first["masks"][t], "gray"), ("true held object", first["truth"][t], "gray")]
    fig, axes = plt.subplots(1, len(panels), figsize=(2.4 * len(panels), 2.8))
    for ax, (title, image, cmap) in zip(axes, panels):
        if cmap == "RdBu_r":
            lim = max(float(np.abs(image).max()), 1e-6)
            im = ax.imshow(image, cmap=cmap, vmin=-lim, vmax=lim)
            fig.colorbar(im, ax=ax, fraction=0.046)
        else:
            ax.imshow(image, cmap=cmap)
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    fig.suptitle(f"frame {t} of the first long recording, where our mask overlaps the truth most (LfD 2009 Fig. 3)",
                 fontsize=9)
    fig.tight_layout()
    return fig


def object_mask_sheet(first, n_frames: int = 6) -> plt.Figure:
    """The hand's window, the true held object, ours, the peer's and the learned pixels' masks in `n_frames`
    frames evenly spaced over the first long recording's truly held, tracked frames (not chosen by outcome)."""
    held = np.flatnonzero(first["truth"].any(axis=(1, 2)) & first["tracked"])
    frames = held[np.linspace(0, held.size - 1, min(n_frames, held.size)).astype(int)] if held.size else held
    rows = [("window", lambda t: window(first["grey"][t], np.asarray(first["hand"])[t], first["half"])),
            ("truth", lambda t: first["truth"][t]), ("ours (phase)", lambda t: first["masks"][t]),
            ("peer", lambda t: first["peer"][0][t]), ("learned", lambda t: first["learned"][t])]
    fig, axes = plt.subplots(len(rows), max(len(frames), 1), figsize=(1.6 * max(len(frames), 1), 1.7 * len(rows)),
                             squeeze=False)
    for j, t in enumerate(frames):
        for i, (name, image) in enumerate(rows):
            axes[i, j].imshow(image(t), cmap="gray")
            axes[i, j].set_title(f"{name}, frame {t}" if i == 0 else name, fontsize=7)
    for ax in axes.ravel():
        ax.axis("off")
    fig.suptitle("object masks in the hand's window, held frames evenly spaced over the first long recording",
                 fontsize=8)
    fig.tight_layout()
    return fig


def _period_labels(ax, first, fps: float) -> None:
    """Above each found period: its CHCRF label (eq. 9) with P(a, o | x), with the history prior (eq. 10),
    and Z(x)."""
    labels = first.get("labels")
    if not labels:
        return
    found, periods = labels["found"], labels["found_periods"]
    for k, (a, b) in enumerate(zip(periods.pickup, periods.putdown)):
        lines = []
        for name, lj in (("eq. 9", found.log_joint[k]), ("+ history", found.log_joint_history[k])):
            i, j = np.unravel_index(np.argmax(lj), lj.shape)
            lines.append(f"{name}: {ACTIONS[i]} {OBJECTS[j]} {np.exp(lj[i, j]):.2f}")
        lines.append(f"Z = {np.exp(found.log_z[k]):.2g} ({np.exp(found.log_z_sequence[k]):.2g} over all labellings)")
        y = 3.5 + 0.75 * (k % 2)  # alternate rows, so that the labels of adjacent short periods do not overlap
        ax.text((a + b) / 2 / fps, y + 0.05, "\n".join(lines), ha="center", va="bottom", fontsize=5.5,
                color="tab:blue")
        ax.plot([a / fps, b / fps], [y, y], color="tab:blue", lw=1)


def object_in_hand(first, fps: float) -> plt.Figure:
    """Fig. 8: per frame the raw "object in hand" (of the hand-window classifier where it ran, else a
    mask found where the hand moved), the filtered classification with its periods and each period's
    CHCRF label, and the truth, over the first long recording."""
    rec, periods = first["rec"], first["periods"]
    T = len(first["raw"])
    truth = np.zeros(T, bool)
    for a, b in zip(rec.pickup_frames, rec.putdown_frames):
        truth[a:b + 1] = True
    t = np.arange(T) / fps
    fig, ax = plt.subplots(figsize=(max(12.0, T / fps / 2.5), 4.2))
    ax.fill_between(t, 2.1, 2.1 + 0.8 * truth, step="post", color="k", alpha=0.7, label="truth")
    ax.fill_between(t, 1.05, 1.05 + 0.8 * periods.in_hand, step="post", color="tab:blue", alpha=0.7,
                    label="filtered (periods)")
    raw = first["raw"] & first["decided"]
    by_classifier = first["source"] == "classifier"
    ax.fill_between(t, 0, 0.8 * raw, step="post", color="tab:orange", alpha=0.7,
                    label="raw (hand-window classifier)" if by_classifier else "raw (mask found, hand moved)")
    ax.fill_between(t, 0, 0.8 * (~first["decided"]), step="post", color="0.85", alpha=0.7,
                    label="undecided (hand lost)" if by_classifier else "undecided (hand still or lost)")
    oracle = first["labels"]["true"] if first.get("labels") else None
    for k, (a, b, act, obj) in enumerate(zip(rec.pickup_frames, rec.putdown_frames, rec.event_action,
                                             rec.event_object)):
        text = f"{ACTIONS[act]} {OBJECTS[obj]}"
        if oracle is not None:  # the CHCRF on the true period: what a perfect temporal segmentation would give
            i, j = np.unravel_index(np.argmax(oracle.log_joint[k]), oracle.log_joint[k].shape)
            text += f"\nCHCRF on it: {ACTIONS[i]} {OBJECTS[j]} {np.exp(oracle.log_joint[k][i, j]):.2f}"
        ax.text((a + b) / 2 / fps, 2.95, text, ha="center", va="bottom", fontsize=6)
    _period_labels(ax, first, fps)
    ax.set_yticks([0.4, 1.45, 2.5], ["raw", "filtered", "truth"])
    ax.set_xlabel("time (s)")
    ax.set_ylim(0, 5.4 if first.get("labels") else 3.3)
    ax.legend(fontsize=7, loc="upper right", ncol=4, bbox_to_anchor=(1, -0.25))
    ax.set_title("object in hand over the first long recording (LfD 2009 Fig. 8); blue, top: the CHCRF label "
                 "(eq. 9, then with eq. 10's history) and Z(x) of each found period", fontsize=9)
    fig.tight_layout()
    return fig



def iou_by_motion(failure: dict) -> plt.Figure:
    """Pooled object IoU of ours, the peer and the learned pixels by the held object's depth offset from the
    hand and by its in-plane rotation speed (`stages.failure_cases`)."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3))
    for ax, what, label in ((axes[0], "depth_offset_cm", "|depth offset from the hand| (cm)"),
                            (axes[1], "rotation_deg_per_frame", "in-plane rotation (degrees / frame)")):
        bins = list(failure[f"{what}_ours"])
        x = np.arange(len(bins))
        for dx, name in ((-0.27, "ours"), (0.0, "peer"), (0.27, "learned")):
            ax.bar(x + dx, [failure[f"{what}_{name}"][b] for b in bins], width=0.27, label=name)
        ax.set_xticks(x, bins, fontsize=7)
        ax.set_xlabel(label)
        ax.set_ylabel("object IoU (pooled)")
        ax.legend(fontsize=7)
    fig.suptitle("object-mask IoU against LfD 2009 §III-B's failure cases", fontsize=9)
    fig.tight_layout()
    return fig
