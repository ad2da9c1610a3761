"""report.md of the video segmentation study."""
from __future__ import annotations

from experiments.config import markdown_table
from experiments.video_segmentation.real_background import METHODS as BACKGROUND_METHODS
from experiments.video_segmentation.real_person import METHODS as PERSON_METHODS
from experiments.video_segmentation.real_skin import METHODS, VALIDATION_PERSONS
from lfd_jax import REAL_SKIN_PERSONS


def _f(v, digits=3):
    return "–" if v is None or v != v else f"{v:.{digits}f}"


def _rendered(cfg, m: dict) -> str:
    rows = [["(a) skin colour alone (hog_jax.segment)", _f(m["iou_hand_skin_only"]), _f(m["iou_face_skin_only"]), "–", "–",
             _f(m["hand_centroid_error_px_skin_only"], 1), _f(m["hand_centroid_error_px_merged_skin_only"], 1)],
            ["(b) level sets + background model", _f(m["iou_hand_levelset_no_tracking"]),
             _f(m["iou_face_levelset_no_tracking"]), "–", "–", _f(m["hand_centroid_error_px_levelset_no_tracking"], 1),
             _f(m["hand_centroid_error_px_merged_levelset_no_tracking"], 1)],
            ["(c) (b) + α-β tracking", _f(m["iou_hand"]), _f(m["iou_face"]), _f(m["iou_person"]), _f(m["iou_object"]),
             _f(m["hand_centroid_error_px"], 1), _f(m["hand_centroid_error_px_merged"], 1)]]
    table = markdown_table(["method", "IoU hand", "IoU face", "IoU person", "IoU object", "hand centroid px (median)",
                            "same, hand touching face"], rows)
    return f"""## Rendered recordings

Recordings: `experiments.data.video` preset `{cfg.video_preset}`; skin models from the first
{cfg.n_skin_persons} person(s), evaluated on {m['n_clips']} clips of the others ({m['n_hand_frames']} frames with
the hand in view, {m['n_merged_frames']} of them with the hand touching the face). IoUs pooled over the
segmentation phase; a frame where a method finds no hand counts as a miss.

{table}

Hand found: (a) {_f(m['hand_found_rate_skin_only'])}, (b) {_f(m['hand_found_rate_levelset_no_tracking'])},
(c) {_f(m['hand_found_rate_full'])} of the frames. 3-D hand error (triangulated tracked centroid against the hand
body's centre, so it includes the hand's half-thickness): median {_f(m['hand_error_3d_cm'], 1)} cm, found in 3-D
in {_f(m['hand_found_3d_rate'])} of the frames.

The TR says the level-set segmentation locates the hand more robustly than skin colour alone: compare the
rows above (IoU and centroid error, all frames and the frames where hand and face touch).
"""


def _background(cfg, m: dict) -> str:
    names = m.get("real_sequences_scored") or []
    if not names:
        return "## Real video: background\n\nNo real sequence found under `" + cfg.real_data + "`: skipped.\n"
    shown = ("ours", "mog2", "knn")
    header = (["sequence"] + [f"F1 {x}" for x in BACKGROUND_METHODS]
              + [f"precision / recall {x}" for x in shown])
    rows = [[n] + [_f(m[f"f1_{n}_{x}"]) for x in BACKGROUND_METHODS]
            + [f"{_f(m[f'precision_{n}_{x}'])} / {_f(m[f'recall_{n}_{x}'])}" for x in shown] for n in names]
    rows.append(["mean"] + [_f(m[f"f1_mean_{x}"]) for x in BACKGROUND_METHODS] + [""] * len(shown))
    verdicts = []
    for peer in ("mog2", "mog2_median3", "knn", "knn_median3"):
        below = [n for n in names if m[f"f1_{n}_ours"] < m[f"f1_{n}_{peer}"]]
        verdicts.append(f"at least {peer}'s on every sequence" if not below else
                        f"below {peer}'s on {len(below)} of {len(names)} ({', '.join(below)})")
    verdict = "Our F1 is " + "; ".join(verdicts) + "."
    return f"""## Real video: background

Every frame of each sequence through each model (ours: `BackgroundOptions.real_video()` with
`BackgroundStructure.real_video()`, one setting for all, ending in a 3 x 3 median of the mask; MOG2 and
KNN: OpenCV's defaults, raw and with the same 3 x 3 median); scored every {cfg.real_step}th evaluated frame by
CDnet's convention (hard shadow is background; unknown and out-of-ROI pixels ignored), counts pooled per
sequence.
{verdict}

{markdown_table(header, rows)}

Contact sheets: `background_<sequence>.png` (green hit, red false alarm, blue miss).
"""


def _person(cfg, m: dict) -> str:
    names = m.get("person_sequences_scored") or []
    if not names:
        return "## Real video: the person\n\nNo SBI sequence was scored: skipped.\n"
    rows = [[n, *(f"{_f(m[f'person_f1_{n}_{k}'])} ({_f(m[f'person_precision_{n}_{k}'])} / "
                  f"{_f(m[f'person_recall_{n}_{k}'])})" for k in PERSON_METHODS)] for n in names]
    return f"""## Real video: the person

The whole front end (`VideoOptions.real_video()`: background model, colour models learnt before frame
{cfg.real_person_start}, level sets) on the SBI indoor sequences, from frame {cfg.real_person_start} on, against
their foreground masks (people and the objects they leave): the level sets' foreground is every region
but the background (person, skin, object); beside it, the background model's own foreground of the same run.

{markdown_table(["sequence", "F1 (P / R) front end", "F1 (P / R) background model"], rows)}

Contact sheets: `person_<sequence>.png` (green hit, red false alarm, blue miss).
"""


def _reach(m: dict) -> str:
    if not m.get("reach_scored"):
        return "## Real video: the reach clip\n\nThe clip was not found: skipped.\n"
    parts = [p for p in ("face", "right_hand", "left_hand") if f"reach_{p}_on_part" in m]
    rows = [[p.replace("_", " "), _f(m[f"reach_{p}_on_part"], 2), _f(m[f"reach_{p}_centre_distance_px"], 1)] for p in parts]
    return f"""## Real video: the reach clip

The front end on the real reach clip ({m['reach_frames']} frames); each tracked part against the project's
own boxes on eight frames (drawn by eye, about 3 px uncertain; a point within 4 px of its box counts; a frame
where the part is not tracked counts as a miss). The frames before frame {m['reach_start']} teach the colour models and
carry no tracks: {m['reach_annotated_before_start']} of the annotated frames are among them. Skin is
{_f(100 * m['reach_skin_fraction'], 1)} % of the pixels.

{markdown_table(["part", "on the part (share of annotated frames)", "distance to box centre, px (median)"], rows)}

Contact sheet: `reach_clip_sheet.png` (boxes and tracked points: face yellow, right hand red, left hand blue).
"""


def _skin(m: dict) -> str:
    if not m.get("skin_photos_scored"):
        return "## Real photos: skin\n\nThe HGR photos were not found: skipped.\n"
    rows = [[f"{part} ({m[f'skin_{part}_photos']} photos)",
             *(f"{_f(m[f'skin_iou_{part}_{k}'], 3)} / {_f(m[f'skin_mean_photo_iou_{part}_{k}'], 3)}" for k in METHODS)]
            for part in ("validation", "test")]
    return f"""## Real photos: skin

The one skin model of stills and video (fitted on UCI pixels and the HGR persons {', '.join(REAL_SKIN_PERSONS)})
beside the fixed YCrCb rule, on the HGR hand photos of the other persons at half size, both masks median-filtered
(3 x 3, three times); validation: the persons {', '.join(VALIDATION_PERSONS)} the model's settings were chosen on
(`experiments.skin_real`), test: the rest. IoU pooled over the photos / mean of the per-photo IoUs.

{markdown_table(["persons", "ours", "YCrCb rule"], rows)}
"""


def report(cfg, m: dict, runtime_s: float) -> str:
    sections = [_rendered(cfg, m)] if cfg.rendered else []
    if cfg.real:
        sections += [_background(cfg, m), _person(cfg, m), _reach(m), _skin(m)]
    body = "\n".join(sections)
    return f"""# Video segmentation (LEVELSET TR §3-5, LfD 2009 §III-A)

{body}
Run time {runtime_s:.0f} s.
"""
