"""report.md of the video segmentation study."""
from __future__ import annotations

from experiments.config import markdown_table


def _f(v, digits=3):
    return "–" if v is None or v != v else f"{v:.{digits}f}"


def report(cfg, m: dict, runtime_s: float) -> str:
    rows = [["(a) skin colour alone (hog_jax.segment)", _f(m["iou_hand_skin_only"]), _f(m["iou_face_skin_only"]), "–", "–",
             _f(m["hand_centroid_error_px_skin_only"], 1), _f(m["hand_centroid_error_px_merged_skin_only"], 1)],
            ["(b) level sets + background model", _f(m["iou_hand_levelset_no_tracking"]),
             _f(m["iou_face_levelset_no_tracking"]), "–", "–", _f(m["hand_centroid_error_px_levelset_no_tracking"], 1),
             _f(m["hand_centroid_error_px_merged_levelset_no_tracking"], 1)],
            ["(c) (b) + α-β tracking", _f(m["iou_hand"]), _f(m["iou_face"]), _f(m["iou_person"]), _f(m["iou_object"]),
             _f(m["hand_centroid_error_px"], 1), _f(m["hand_centroid_error_px_merged"], 1)]]
    table = markdown_table(["method", "IoU hand", "IoU face", "IoU person", "IoU object", "hand centroid px (median)",
                            "same, hand touching face"], rows)
    real = ("skipped (no CDnet folder)" if m.get("real_skipped") else
            f"F1 ours {_f(m['real_f1_ours'])}, MOG2 {_f(m['real_f1_mog2'])}, KNN {_f(m['real_f1_knn'])} "
            f"over {m['real_eval_frames']} evaluated frames (470..{cfg.cdnet_last})")
    return f"""# Video segmentation (LEVELSET TR §3-5, LfD 2009 §III-A)

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

Real video (CDnet highway, background model): {real}.

Run time {runtime_s:.0f} s.
"""
