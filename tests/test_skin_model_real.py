"""experiments.skin_real's one-model study: the gtea scores and the hands-found matching against brute
force, the annotation mask on drawn lines, and a smoke run on a few real photos and frames (skipped
without ../shared/data)."""
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from experiments.data.hand_photos import GteaFrame, annotation_mask, hgr_split, missing_data, person_of
from experiments.skin_real import main
from experiments.skin_real.one_model import box_iou, gtea_scores, hands_found, median_filtered

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def test_box_iou_and_hands_found():
    assert box_iou((0, 0, 10, 10), (0, 0, 10, 10)) == 1.0
    assert box_iou((0, 0, 10, 10), (5, 0, 15, 10)) == pytest.approx(50 / 150)
    assert box_iou((0, 0, 4, 4), (5, 5, 9, 9)) == 0.0
    mask = np.zeros((40, 50), bool)
    mask[2:12, 3:13] = True     # matches the first box exactly
    mask[20:38, 30:48] = True   # the largest blob, half inside the second box
    mask[0:2, 45:47] = True     # a speck, never among the k largest
    boxes = np.array([(2, 3, 12, 13), (20, 30, 38, 39)])
    # blob 2 is (20, 30, 38, 48) against (20, 30, 38, 39): IoU 9/18 = 0.5 -> found
    assert hands_found(mask, boxes) == 2
    assert hands_found(mask, boxes, min_iou=0.6) == 1
    assert hands_found(np.zeros((40, 50), bool), boxes) == 0


def test_gtea_scores_leave_the_annotation_out():
    h, w = 20, 30
    in_box = np.zeros((h, w), bool)
    in_box[5:15, 5:15] = True
    ignore = np.zeros((h, w), bool)
    ignore[5, 5:15] = True      # a drawn line on the box's top edge
    frame = GteaFrame("f", np.zeros((h, w, 3), np.float32), ignore, np.array([(5, 5, 15, 15)]), in_box)
    mask = np.zeros((h, w), bool)
    mask[6:15, 5:10] = True     # 45 pixels inside
    mask[0:3, 20:30] = True     # 30 outside
    mask[5, 5:15] = True        # on the line: counts nowhere
    s = gtea_scores([mask], [frame])
    assert s["in_box_skin"] == pytest.approx(45 / 90)
    assert s["skin_outside_boxes"] == pytest.approx(30 / 75)
    assert s["n_hands"] == 1 and s["hands_found_rate"] == 0.0  # the largest blob is the outside one


def test_annotation_mask_finds_drawn_boxes_and_text():
    bgr = np.full((60, 80, 3), 120, np.uint8)
    cv2.rectangle(bgr, (10, 15), (50, 45), (255, 0, 0), 2)   # a blue box (BGR)
    cv2.putText(bgr, "ab", (12, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.3, (0, 0, 255), 1)  # red text above it
    mask = annotation_mask(bgr, [(10, 15, 50, 45)])
    drawn = np.abs(bgr.astype(int) - 120).max(-1) > 60
    assert mask[drawn].all()
    assert not mask[30, 30] and not mask[55, 75]  # the box's inside and far away stay


def test_median_filtered_equals_hog_jax_median3():
    from hog_jax import median3
    rng = np.random.default_rng(0)
    m = rng.random((17, 23)) < 0.5
    np.testing.assert_array_equal(median_filtered(m), np.asarray(median3(m[None], 3))[0])


def test_hgr_split_by_person():
    names = ["1_P_hgr1_id01_1", "1_P_hgr1_id04_2", "A_P_hgr1_id08_1", "x"]
    assert person_of(names[1]) == "id04" and person_of("x") == ""
    split = hgr_split(names, ("id01",), ("id04",))
    assert split == {"fit": names[:1], "validation": names[1:2], "test": names[2:]}


def test_one_model_smoke_on_real_data(tmp_path):
    if missing_data(DATA):
        pytest.skip(f"real data absent: {DATA} (skin_nonskin_uci.tsv and hgr_hands/; see ../shared/data/README.md)")
    out = tmp_path / "run"
    written = main(["--data", str(DATA), "--preset", "model_quick", "--n-photos", "2", "--n-iter", "10",
                    "--fit-pixels", "2000", "--uci-validation-pixels", "1000", "--rule-photos", "2",
                    "--photo-scale", "0.2", "--gtea-frames", "2", "--gtea-scale", "0.2", "--relevances", "64",
                    "--thresholds", "0,2", "--reach-sheet-frames", "1", "--out", str(out)])
    assert json.loads((out / "metrics.json").read_text()) == written
    for v in ("ycrcb", "generic", "rules", "adapted"):
        assert 0.0 <= written[f"hgr_test_{v}_iou"] <= 1.0, v
    assert written["hgr_test_generic_iou"] > 0.3  # a broken model or a swapped colour order scores far lower
    for name in ("report.md", "skin_model.npz"):
        assert (out / name).stat().st_size > 0, name
