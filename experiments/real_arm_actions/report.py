"""report.md of the real-arm action study: one table per data kind (accuracy per held-out person,
mean, confusion, training and test time per method), the side PHMMs, and how settings were chosen."""
from __future__ import annotations

from collections import Counter

import numpy as np

from experiments.config import markdown_table
from experiments.data.ue_adl import ACTIONS
from experiments.real_arm_actions.config import METHOD_NAMES

PROTOCOL = """\
**Protocol.** Four actions (F forward reach, A reach across, D drink, C comb hair), both arms, 5
trials each per person. Every trial is resampled to {n_frames} frames and every feature z-scored with
the mean and standard deviation of the training persons' frames. Each method is trained on the
training persons of a fold and tested on its held-out person(s) (leave-one-person-out, or
`--train DIR --test DIR`); the accuracy of a method is the mean over held-out persons of the share of
their trials it labels correctly (chance 25 %). The three HMM methods train one model per action
(both arms pooled) and label a trial by the highest log-likelihood; 1-NN DTW labels it by its
nearest training trial (tslearn, unconstrained DTW).

**Choice of settings, never on the held-out person.** For each fold and HMM method the number of
states ({states}) and covariance type ({covariances}) are chosen by the mean accuracy on
{n_val} inner leave-one-person-out validation fold(s) drawn among the fold's training persons
(fixed for all: covariance floor {reg} in standardised units, {n_iter} EM iterations at most,
explicit durations within (1 ∓ {spread}) × frames per state, {n_frames}-frame resampling, z-scoring);
the chosen model is then retrained on all training persons. Training time is that final fit over
all folds (JAX compilation included in the first folds); selection time is reported apart.

**The parameter: reach side.** UE-ADL gives no reach targets, so the one parameter the recordings have
is the arm used (L/R). Per action a 1-D PHMM over the side (corner φ = 0 trained on the left-arm
trials, φ = 1 on the right-arm ones, synchronised local training, PHMM §III-B1) with the fold's
chosen explicit-duration setting and a covariance floor chosen on the fold's training persons (inner
leave-one-person-out folds, lowest mean |φ − side|, `side_floors`; metric `side_floors_chosen`);
recognition (PHMM eq. 3, ε = 0.1) gives the action
(the best PHMM) and φ; the side is "right" when φ of the true action's PHMM exceeds 0.5. Beside it
the regression baseline: per action an affine least-squares map from the final fingertip
positions (the frame farthest from the first; the angle files have no fingertip, so all 11 columns
there) to the side; metrics `side_error_*` are the mean |φ − side| of both."""


def header(cfg, kinds: list[str], runtime_s: float) -> str:
    source = (f"leave-one-person-out over `{cfg.data}`" if cfg.train is None
              else f"trained on `{cfg.train}`, tested on `{cfg.test}`")
    return "\n\n".join([
        "# Real arm actions: UE-ADL daily-living actions from joint angles and raw markers",
        f"Data: {source}; kinds: {', '.join(kinds)}. Run time {runtime_s:.0f} s (all stages).",
        PROTOCOL.format(n_frames=cfg.n_frames, states=", ".join(map(str, cfg.grid_states)),
                        covariances=", ".join(cfg.grid_covariance), n_val=cfg.n_validation_folds,
                        reg=cfg.reg_covar, n_iter=cfg.n_iter, spread=cfg.duration_spread)])


def _confusion_cell(counts) -> str:
    return " / ".join(" ".join(str(c) for c in row) for row in counts)


def _settings_cell(settings) -> str:
    if settings[0] is None:
        return "–"
    return ", ".join(f"{s} ×{n}" for s, n in Counter(map(str, settings)).most_common())


def section(kind: str, folds, results: dict, side, cfg) -> str:
    train = folds[0][0]
    persons = list(next(iter(results.values())).per_person())
    n_trials = len(results["edhmm"].truth)
    features = ("11 columns of the processed files (finger velocity, 10 joint angles)" if kind == "angles" else
                "10 points relative to the sternum (shoulder, upper-arm, forearm, hand cluster centroids and "
                "fingertip of each arm), 30 coordinates")
    rows = []
    for method, r in results.items():
        acc = r.per_person()
        rows.append([METHOD_NAMES[method], *(f"{100 * acc[p]:.1f}" for p in persons), f"**{100 * r.accuracy:.1f}**",
                     f"{r.train_s:.1f} ({np.median(r.train_s_per_fold):.2f})", f"{r.test_s:.1f}",
                     f"{r.selection_s:.1f}", _settings_cell(r.settings), _confusion_cell(r.confusion())])
    if side is not None:
        side_acc = side.per_person(side.side_correct)
        action_acc = side.per_person(side.action == side.truth)
        rows.append(["side PHMMs: action", *(f"{100 * action_acc[p]:.1f}" for p in persons),
                     f"**{100 * sum(action_acc.values()) / len(action_acc):.1f}**", f"{side.train_s:.1f}",
                     f"{side.test_s:.1f}", "–", "as edhmm", "–"])
        floors = ", ".join(f"{f:g}" for f in side.floors)
        rows.append(["side PHMMs: side (L/R)", *(f"{100 * side_acc[p]:.1f}" for p in persons),
                     f"**{100 * sum(side_acc.values()) / len(side_acc):.1f}**", "", "", "–",
                     f"as edhmm, covariance floor {floors}", "–"])
        reg_acc = side.per_person(side.regression_correct)
        rows.append(["baseline: side (L/R) by linear regression from the final fingertips", *(
            f"{100 * reg_acc[p]:.1f}" for p in persons), f"**{100 * sum(reg_acc.values()) / len(reg_acc):.1f}**",
            "", "", "–", "–", "–"])
    table = markdown_table(["method", *persons, "mean", "train s (median fold)", "test s", "selection s",
                            "settings chosen (folds)", f"confusion, rows true {' '.join(ACTIONS)}"], rows)
    side_note = ("" if side is not None else
                 "\n\nNo side PHMMs: a training fold lacks the left- or right-arm trials of an action.")
    return (f"## {kind}\n\n{n_trials} test trials of {len(persons)} held-out person(s) in {len(folds)} fold(s); "
            f"{len(train.action)} training trials in the first fold. Features: {features}. Accuracy in % per "
            "held-out person; times in seconds summed over folds (in brackets the median fold's training: the "
            "first folds include compilation, JAX's and tslearn's numba); confusion rows F / A / D / C, columns "
            f"recognised in the same order (figure `confusion_{kind}.png`).\n\n{table}{side_note}")


def skipped(message: str) -> str:
    return f"# Real arm actions\n\n{message}"
