"""report.md of the learning-from-demonstration study, beside LfD 2009's figures."""
from __future__ import annotations

from experiments.config import markdown_table
from experiments.lfd_demonstration.boundaries import SEARCH_AFTER_S, SEARCH_BEFORE_S
from experiments.data.oac_protocol import PAPER_LFD_CORRECT, PAPER_TABLE2, PAPER_TABLE3, PAPER_TABLE4

PAPER = {"pickup_error_frames": 1.2, "putdown_error_frames": 3.4}  # LfD 2009 §V: all 5 actions found


def clips_text(cfg, settings, m: dict) -> str:
    """The OAC tables from the clips' pipeline features, beside the renderer masks' and the paper's."""
    if "table2" not in m:
        return ""
    return f"""## OAC tables from what the cameras see (ECCV 2008 Tables 2-4, LfD 2009 Table I)

{m['clips_n']} pre-segmented clips ({len(cfg.clip_persons(settings))} persons x 3 OACs x {cfg.clip_repetitions}; the
paper: 10 x 3 x 5) through the same front end; per frame of the pick-up..put-down segment at {cfg.feature_fps:g} fps:
the tracked hand minus face in 2-D and 3-D, the HOG (B = 4, L = 4) of the skin pixels near the tracked hand, the
HOG (B = 4, L = 1, square-normalised) of our phase-difference object mask in the hand's window. "Renderer masks":
the same features from the renderer's ground truth of the same frames (true hand and face ellipses, hand-skin and held-object
labels). The OAC study's protocol unchanged: leave-one-person-out, {cfg.n_runs} runs, error % median (max).
{m['clips_hand_lost']} clip(s) lost the hand; a hand HOG exists in {100 * m['clips_hand_hog_rate']:.1f} % of the
pipeline's frames ({100 * m['clips_hand_hog_rate_renderer']:.1f} % with the renderer's masks).

{markdown_table(["table", "cell", "pipeline", "renderer masks", "paper"], table_rows(m))}
"""


def labels_text(cfg, m: dict) -> str:
    section = labels_section(m)
    if not section:
        return ""
    return f"""## Each OAC of the long recordings classified (LfD §V, Fig. 8, eqs. 9-10)

The CHCRF (action CRF on 3-D position + hand HOG, object CRF on the object HOG, K(a, o) of the training clips)
trained on the clips of the other persons; each found period classified, then the object-history prior of eq. 10
over the periods before it (default distance δ_0 = {cfg.history_distance_px:g} px at 320 x 240).
Z(x) = sum K(a, o) P(a | x) P(o | x), with P(a | x) the pre-segmented CRF's probability of [a, ..., a] among the
K constant labellings (at most max K, whatever the length), and, second row, among all K^T labellings (falls with every ambiguous frame); the
paper's used unnormalised potentials, so only orders of magnitude between OACs compare. "True periods" repeats it
on the ground-truth segmentation, to separate the temporal segmentation's errors from the classifier's.

{section}
"""


def _f(v, digits=3):
    return "–" if v is None or v != v else f"{v:.{digits}f}"


def report(cfg, settings, m: dict, runtime_s: float) -> str:
    def errors(prefix, kind):
        return f"{_f(m[f'{prefix}{kind}_error_frames'], 1)} / {_f(m[f'{prefix}{kind}_error_frames_median'], 1)}"

    def counts(prefix):
        return f"{m[prefix + 'events_matched']} / {m[prefix + 'events_missed']} / {m[prefix + 'events_spurious']}"

    classified = cfg.clip_repetitions > 0
    learned = _f(m["object_mask_iou_learned"]) if classified else "not run"
    rows = [["object-mask IoU in the hand's window (pooled)", _f(m["object_mask_iou"]),
             _f(m["object_mask_iou_peer"]), learned, "–"],
            ["the same within the classifier's periods", _f(m["object_mask_iou_in_periods"]),
             _f(m["object_mask_iou_peer_in_periods"]), learned, "–"],
            ["pick-up error, frames (mean / median)", errors("", "pickup"), errors("peer_", "pickup"),
             errors("classifier_", "pickup") if classified else "not run", "1.2"],
            ["put-down error, frames (mean / median)", errors("", "putdown"), errors("peer_", "putdown"),
             errors("classifier_", "putdown") if classified else "not run", "3.4"],
            ["events matched / missed / spurious", counts(""), counts("peer_"),
             counts("classifier_") if classified else "not run", "5 / 0 / 0"]]
    table = markdown_table(["quantity", "ours (phase, LfD §III-B)", "peer (StereoSGBM + DIS)",
                            "hand-window classifier; learned object pixels", "paper"], rows)
    per = markdown_table(["recording", "person", "frames", "σ_m px", "hand tracked", "IoU ours", "IoU peer",
                          "IoU learned", "true events", "found ours", "found peer", "found classifier"],
                         [[k, r["person"], r["frames"], _f(r.get("sigma_px"), 1), _f(r.get("tracked"), 2),
                           _f(r.get("ours_iou")), _f(r.get("peer_iou")),
                           _f(r.get("learned_iou")) if classified else "–", r["true_events"],
                           r.get("ours_found_events", 0), r.get("peer_found_events", 0),
                           r.get("classifier_found_events", "–")]
                          for k, r in m["recordings"].items()])
    by = m.get("iou_by")
    failure = "" if not by else "Object IoU against the paper's failure cases (held frames binned):\n\n"
    failure += "" if not by else markdown_table(
        ["bin", "depth offset (cm): ours", "peer", "learned", "rotation (deg / frame): ours", "peer", "learned"],
        [[b, *(_f(by[f"depth_offset_cm_{name}"][b]) for name in ("ours", "peer", "learned")),
          *(_f(by[f"rotation_deg_per_frame_{name}"][r]) for name in ("ours", "peer", "learned"))]
         for b, r in zip(by["depth_offset_cm_ours"], by["rotation_deg_per_frame_ours"])])
    return f"""# Learning from an unsegmented demonstration (LfD 2009 §III-B, §III-D)

Recordings: {m['n_recordings']} long unsegmented scripts of `experiments.data.video` preset `{cfg.video_preset}`
({settings.width} x {settings.height} at {settings.fps:g} fps, {m['events_true']} true pick-up / put-down periods),
each through the video front end (skin models from the clips of the last {cfg.n_skin_persons}
person(s), who have no script): level sets, tracking, the tracked right hand in both views. The object in the
hand: phase differences in a {2 * round(cfg.half_window * cfg.scale(settings)) + 1}-pixel window centred on the
hand's end of its skin blob, not the centroid of hand and bare forearm (`front.hand_tip`) (ours), and the
OpenCV peer on the same windows and hand positions. A frame decides "object in hand" only where the hand moved at
least {cfg.min_hand_motion:g} px (at 320 x 240) and is tracked in both views, else it keeps the last decision; then
the closing and opening over time and periods under {cfg.min_duration_s:g} s removed. The paper's rule (a frame
holds an object where its mask is not empty) is applied to ours and the peer's masks. "Hand-window classifier": a
logistic regression on the HOG of a window twice as wide around the hand (`in_hand`), trained on the pre-segmented
clips of the other persons (none with `--clip-repetitions 0`), gives every tracked frame log odds of "held"; a
two-state Viterbi path with a cost per switch (0.64 nats x fps) decides the frames, the same filter follows,
then each pick-up moves to the frame where the tracked hand is slowest from {SEARCH_BEFORE_S:g} s before it to
{SEARCH_AFTER_S:g} s after it, each put-down likewise from {SEARCH_AFTER_S:g} s before to {SEARCH_BEFORE_S:g} s after (`boundaries`: the hand stops where it grasps and lets
go, before the object looks held and after it looks put down), and these periods are the ones the CHCRF labels
below. "Learned object pixels" (`object_pixels`): a per-pixel
logistic regression on where held objects lie relative to the hand's tip (their frequency in the clips' windows),
the phase cues and the front end's labels, trained on the clips of the other persons (the renderer's object
masks of their held frames); a pixel is the object's where its log odds exceed -1, in the classifier's periods
only. Object IoUs pool the windows of every frame of a recording (a mask outside the held frames counts against
it); "within the classifier's periods" keeps ours and the peer's masks in the same frames as the learned ones (figure `object_masks.png`: the three
masks in held frames evenly spaced over the first recording). A found period matches the true
one it overlaps most; errors are |found - true| in frames. A recording where the hand is never found is
flagged (no σ_m, IoU "–") and its true events count as missed.

{table}

{per}

{failure}

The paper reports all 5 actions of its one demonstration found, with errors of 1.2 frames (pick-up) and 3.4
(put-down).

{clips_text(cfg, settings, m)}

{labels_text(cfg, m)}

Run time {runtime_s:.0f} s.
"""


def _pct(cell: dict | None) -> str:
    return "–" if cell is None else f"{cell['error_pct']['median']:.1f} ({cell['error_pct']['max']:.1f})"


def _paper_pct(value) -> str:
    if value is None:
        return "–"
    med, mx = value
    return f"{med:g}" if mx is None else f"{med:g} ({mx:g})"


def table_rows(m: dict) -> list[list[str]]:
    """Every cell of ECCV Tables 2-4 and LfD Table I: from the pipeline's features, from the renderer's
    masks on the same clips, and the paper's (error % median (max); Table I also as % correct)."""
    renderer = m["renderer"]
    rows = []
    for tgt in ("actions", "objects"):
        for method in PAPER_TABLE2[tgt]:
            rows.append([f"Table 2, {tgt}", method, _pct(m["table2"][tgt][method]),
                         _pct(renderer["table2"][tgt][method]), _paper_pct(PAPER_TABLE2[tgt][method])])
    for tgt in ("actions", "objects"):
        for method in PAPER_TABLE3[tgt]:
            rows.append([f"Table 3, {tgt}", method, _pct(m["table3"][tgt][method]),
                         _pct(renderer["table3"][tgt][method]), _paper_pct(PAPER_TABLE3[tgt][method])])
    for cell in PAPER_TABLE4:
        for tgt in ("actions", "objects"):
            rows.append([f"Table 4, {tgt}", cell, _pct(m["table4"][cell][tgt]), _pct(renderer["table4"][cell][tgt]),
                         _paper_pct(PAPER_TABLE4[cell])])
    for dim in ("2d", "3d"):
        for kind in ("shape_and_pos", "pos_only"):
            correct = lambda t: f"{100 - t[dim][kind]['error_pct']['median']:.1f} % correct"  # noqa: E731
            rows.append([f"Table I, {dim.upper()}", kind.replace("_", " "),
                         f"{_pct(m['table1'][dim][kind])}; {correct(m['table1'])}",
                         f"{_pct(renderer['table1'][dim][kind])}; {correct(renderer['table1'])}",
                         f"{PAPER_LFD_CORRECT[dim][kind]:g} % correct"])
    return rows


def labels_section(m: dict) -> str:
    """The CHCRF labels and Z(x) (both normalisations, `labelling`) of the found and the true periods,
    beside LfD §V's check."""
    if "oac_correct_rate" not in m and "true_periods_oac_correct_rate" not in m:
        return ""
    rows = []
    for prefix, name in (("", "found periods (pipeline end to end)"), ("true_periods_", "true periods (oracle)")):
        for suffix, z_name in (("", "over the K labels"), ("_sequence", "over all K^T labellings")):
            g = lambda k: m.get(prefix + k, float("nan"))  # noqa: E731
            z = lambda k: f"{g(k + suffix):.3g}"  # noqa: E731
            rows.append([name, g("oacs"), _f(g("oac_correct_rate"), 2), _f(g("oac_correct_rate_history"), 2), z_name,
                         z("z_seen"), z("z_unseen"), z("z_drink_from_pitcher"), z("z_pour_from_binoculars"),
                         g("z_seen_above_unseen" + suffix), g("z_pitcher_above_binoculars" + suffix)])
    rows.append(["paper (one recording)", 5, "3 of 3 seen near-perfect", "–", "unnormalised potentials", "O(10^7)",
                 "85,000 / 45,000", "85,000", "45,000", True, True])
    return markdown_table(["periods", "OACs with a true label", "CHCRF (eq. 9) correct", "with history (eq. 10)",
                           "P(a given x) normalised", "Z seen (median)", "Z unseen (median)", "Z drink from pitcher",
                           "Z pour from binoculars", "every seen Z > every unseen Z", "pitcher > binoculars"], rows)