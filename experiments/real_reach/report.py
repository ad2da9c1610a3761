"""report.md of the real-reach study: protocol, one size table per feature normalisation (whole
reach and along the reach, per held-out person), PHMM diagnostics, and the event table."""
from __future__ import annotations

from collections import Counter

from experiments.config import markdown_table
from experiments.real_reach.config import METHOD_NAMES, METHODS

PROTOCOL = """\
**Protocol.** Seated right-handed persons reach for a cube of edge S 2.5, M 5.5 or L 7.5 cm (the
reach's parameter). Leave-one-person-out: every method is trained on the other persons' reaches
(onset to contact, the annotations) and tested on the held-out person's; the accuracy is the share
of the held-out reaches whose size is right (pooled over the folds; chance 33 %). Features per
frame: the wrist, the thumb, index and middle finger tips relative to the wrist, and the thumb–index
and thumb–middle apertures, z-scored with the training frames. "Along the reach": every method answers on the first 20–100 %
of the frames (the aperture, regression and DTW baselines are refitted on the training reaches'
prefixes of the same share; the HMMs are trained on whole reaches and score the prefix).
The PHMM's φ is read three ways: snapped to the nearest size; by the nearest class mean of the
training persons' cross-validated φ (each training person's φ from a PHMM fitted on the other
training persons, with the fold's chosen setting: a calibration of φ learnt without the held-out
person); and the same with every φ z-scored over its person's reaches ("z-scored per person": the
held-out person's unlabelled reaches, all three sizes in equal shares, give an offset and scale of
φ — beside it the aperture rule with the same per-person z-score).

**Choice of settings, never on the held-out person.** The PHMM's states ({states}), covariance
floor ({floors}), corners ({grids}: S and L, or S, M and L) and covariances ({covs}: per corner, or
each state's tied across the corners) and hmmlearn's states and floor are
chosen by the mean accuracy on inner leave-one-person-out folds of the training persons (at most
{n_val}); the event detectors' windows, thresholds and delays on the training persons' movements."""


def header(cfg, movements, runtime_s: float) -> str:
    """Title, data, run time and protocol."""
    persons = sorted({m.person for m in movements})
    return "\n\n".join([
        "# Real reaches: object size and reach timing from OpenPose tracks",
        f"Data: `{cfg.data}`, {len(movements)} movements of persons {', '.join(map(str, persons))}. "
        f"Run time {runtime_s:.0f} s.",
        PROTOCOL.format(states=", ".join(map(str, cfg.grid_states)), floors=", ".join(f"{f:g}" for f in cfg.floors),
                        grids=", ".join(cfg.phmm_grids), covs=", ".join(cfg.phmm_covariances),
                        n_val=cfg.n_validation_folds)])


def _settings(settings) -> str:
    return "; ".join(f"{s} ×{n}" for s, n in Counter(map(str, settings)).most_common())


def size_section(r, metrics: dict, normalisation: str, cfg) -> str:
    """The size table of one normalisation and the PHMM's diagnostics."""
    what = {"pixels": "image pixels, the wrist at its absolute position",
            "person": "per person: the wrist relative to its onset position in shoulder widths "
                      "(Neck–RShoulder up to the onset), the fingers in resting hand lengths (palm base – "
                      "middle knuckle up to the onset)",
            "calibrated": "the person features z-scored per person with all of that person's reach frames (an "
                          "offset and scale per feature and person from the person's unlabelled reaches, the "
                          "held-out person's included: a calibration set in which the three sizes are equally "
                          "common)"}[normalisation]
    persons = list(r.per_person(METHODS[0]))
    rows = []
    for m in METHODS:
        pp = r.per_person(m)
        rows.append([METHOD_NAMES[m], *(f"{100 * pp[p]:.1f}" for p in persons), f"**{100 * r.accuracy(m):.1f}**",
                     *(f"{100 * r.accuracy(m, f):.1f}" for f in cfg.fractions if f < 1.0),
                     " / ".join(" ".join(map(str, row)) for row in r.confusion(m))])
    table = markdown_table(["method", *persons, "pooled", *(f"{round(100 * f)} %" for f in cfg.fractions if f < 1.0),
                            "confusion (rows true S M L)"], rows)
    return (f"## Object size, {normalisation} features\n\nFeatures: {what}. {len(r.truth)} held-out reaches. "
            f"Accuracy in % per held-out person and pooled (whole reach), then pooled on the first 20–80 % of the "
            f"reach (figure `accuracy_vs_reach_{normalisation}.png`; confusion `confusion_{normalisation}.png`)."
            f"\n\n{table}\n\n"
            f"PHMM: settings chosen {_settings(r.settings['phmm'])}; hmmlearn {_settings(r.settings['hmmlearn'])}. "
            f"Recognised φ on the search box's edge [−ε, 1 + ε] (ε = {cfg.epsilon}): "
            f"**{100 * r.edge_share:.0f} %** of the reaches; median |size error| "
            f"{metrics['phmm_median_abs_error_cm']:.2f} cm. Along the parameter the log-likelihood of a whole "
            f"reach spans a median {metrics['phmm_loglik_range_per_frame_median']:.2f} nats per frame over "
            f"φ ∈ [0, 1], and the best lattice φ beats the true size's φ by a median "
            f"{metrics['phmm_loglik_gap_true_median']:.1f} nats. The φ lattice ({cfg.n_phi} points) on whole reaches: "
            f"{100 * metrics['phmm_lattice_accuracy']:.1f} %. Recognition "
            f"{metrics['phmm_recognition_ms_per_reach']:.1f} ms per reach (JAX compilation included where it is the first stage).")


def event_section(r, metrics: dict, cfg) -> str:
    """The onset / contact table."""
    rows = []
    for name in r.onset_error:
        key = name.replace(" ", "_")
        rows.append([name, *(f"{metrics[f'{e}_median_abs_error_frames_{key}']:.0f} "
                             f"({metrics[f'{e}_median_error_frames_{key}']:+.0f})" for e in ("onset", "contact")),
                     *(f"{metrics[f'{e}_median_latency_frames_{key}']:+.0f} / "
                       f"{metrics[f'{e}_p90_latency_frames_{key}']:+.0f}" for e in ("onset", "contact"))])
    table = markdown_table(["detector", "onset median abs. error (median error)", "contact median abs. error (median error)",
                            "onset latency median / p90", "contact latency median / p90"], rows)
    chosen = "; ".join(f"w {p[0]}, on {p[1]:g}, stop {p[2]:g}, delays {p[3]:+d} / {p[4]:+d}" for p in r.speed_params)
    return ("## Reach onset and contact, online\n\nFrames at 60 Hz against the annotated onset and end (contact), "
            f"{len(r.person)} movements of the held-out persons (figure `event_errors.png`). Latency: the frame at "
            "which the estimate is known minus the annotated frame (negative: known before the annotated event; "
            "the speed detector's crossing precedes the annotated onset, its learnt delay moves the estimate "
            "later). Both detectors are causal: the speed detector's window speed, running peak and running "
            "shoulder-width scale use frames up to the current one, the HMM's posteriors frames up to the "
            f"current one + ℓ.\n\n{table}\n\nSpeed settings chosen per fold: {chosen}. Event HMM: rest, "
            f"{cfg.reach_states} reach and {cfg.after_states} after-contact states (features: wrist displacement "
            "from the first frame, wrist speed, grip aperture, in shoulder widths).")


def skipped(message: str) -> str:
    """The report of a run without data."""
    return f"# Real reaches\n\n{message}"

