"""experiments.skin_real: metric functions against sklearn, scipy and brute force, the YCrCb
rule against OpenCV, padded batches against per-photo filtering and `hog_jax.segment`, and a smoke
run of the study on three real photos (skipped without ../shared/data)."""
import json
from pathlib import Path

import cv2
import jax
import numpy as np
import pytest
from scipy import ndimage
from sklearn.metrics import jaccard_score, precision_score, recall_score

from experiments.data.hand_photos import Photo, missing_data, pad_photos
from experiments.peers.ycrcb import ycrcb_rule, ycrcb_u8
from experiments.skin_real import main, methods
from experiments.skin_real.metrics import (confusion_counts, hand_found, per_photo_iou, pooled_scores,
                                           threshold_counts)
from hog_jax import fit_skin_model, median3, segment, skin_log_ratio
from lfd_jax import best_iou_threshold

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def _valid(rng, B, H, W):
    """Masks of real pixels: photo b is (h_b, w_b) in the top-left corner of (H, W)."""
    sizes = np.stack([rng.integers(H // 2, H + 1, B), rng.integers(W // 2, W + 1, B)], 1)
    return (np.arange(H)[None, :, None] < sizes[:, :1, None]) & (np.arange(W)[None, None, :] < sizes[:, 1:, None])


def test_pixel_scores_match_sklearn():
    rng = np.random.default_rng(0)
    valid = _valid(rng, 4, 30, 40)
    pred, truth = rng.random((4, 30, 40)) < 0.4, rng.random((4, 30, 40)) < 0.3
    counts = confusion_counts(pred, truth, valid)
    pooled = pooled_scores(counts)
    y_true, y_pred = truth[valid], pred[valid]
    assert pooled["precision"] == pytest.approx(precision_score(y_true, y_pred), abs=1e-12)
    assert pooled["recall"] == pytest.approx(recall_score(y_true, y_pred), abs=1e-12)
    assert pooled["iou"] == pytest.approx(jaccard_score(y_true, y_pred), abs=1e-12)
    reference = [jaccard_score(truth[b][valid[b]], pred[b][valid[b]]) for b in range(4)]
    np.testing.assert_allclose(per_photo_iou(counts), reference, atol=1e-12)
    empty = pooled_scores(np.zeros((2, 3), np.int64))
    assert np.isnan(empty["precision"]) and np.isnan(empty["recall"]) and empty["iou"] == 1.0


def test_hand_found_matches_scipy_largest_component():
    """Random masks at density 0.45 (above 8-connected site percolation: one large component and
    many small ones); the reference labels them with scipy.ndimage (8-connectivity)."""
    rng = np.random.default_rng(1)
    B, H, W = 5, 40, 50
    valid = _valid(rng, B, H, W)
    masks, truth = rng.random((B, H, W)) < 0.45, rng.random((B, H, W)) < 0.5
    found, iou = hand_found(masks, truth, valid, min_iou=0.25)
    for b in range(B):
        labels, n = ndimage.label(masks[b] & valid[b], structure=np.ones((3, 3)))
        areas = np.bincount(labels.ravel())[1:]
        assert (areas == areas.max()).sum() == 1  # no tie, so "the largest" is one component
        largest = labels == 1 + np.argmax(areas)
        t = truth[b] & valid[b]
        ref = (largest & t).sum() / (largest | t).sum()
        assert iou[b] == pytest.approx(ref, abs=1e-12) and found[b] == (ref >= 0.25)
    none_found, none_iou = hand_found(np.zeros((1, 4, 4), bool), np.ones((1, 4, 4), bool), np.ones((1, 4, 4), bool))
    assert not none_found[0] and none_iou[0] == 0.0


def test_best_iou_threshold_matches_brute_force():
    rng = np.random.default_rng(2)
    ratio = np.round(rng.normal(0, 2, 300), 1)  # many ties
    is_skin = rng.random(300) < 1 / (1 + np.exp(-ratio))
    threshold, iou = best_iou_threshold(ratio, is_skin)
    candidates = np.concatenate([np.unique(ratio), [ratio.min() - 1]])
    brute = [pooled_scores(threshold_counts(ratio, is_skin, [t]))["iou"] for t in candidates]
    assert iou == pytest.approx(max(brute), abs=1e-12)
    assert pooled_scores(threshold_counts(ratio, is_skin, [threshold]))["iou"] == pytest.approx(iou, abs=1e-12)
    everything, _ = best_iou_threshold(np.array([1.0, 2.0]), np.array([True, True]))
    assert everything < 1.0


def test_ycrcb_rule_equals_cv2_inrange():
    """Every (R, B) pair at five G levels: OpenCV's 8-bit YCrCb and the Chai & Ngan box via inRange."""
    v = np.arange(256)
    r, g, b = np.meshgrid(v, [0, 64, 128, 192, 255], v, indexing="ij")
    rgb = np.stack([r, g, b], -1).reshape(256 * 5, 256, 3).astype(np.uint8)
    ycc = cv2.cvtColor(rgb, cv2.COLOR_RGB2YCrCb)
    np.testing.assert_array_equal(np.asarray(ycrcb_u8(rgb)), ycc)
    reference = cv2.inRange(cv2.cvtColor(rgb[..., ::-1].copy(), cv2.COLOR_BGR2YCrCb), (0, 133, 77), (255, 173, 127))
    ours = np.asarray(ycrcb_rule(rgb))
    np.testing.assert_array_equal(ours, reference > 0)
    assert 0.01 < ours.mean() < 0.5


def _photos(rng, sizes):
    photos = []
    for h, w in sizes:
        bgr = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        bgr[h // 4:3 * h // 4, w // 4:3 * w // 4] = (110, 140, 200)  # a skin-coloured block (B, G, R)
        photos.append(Photo(f"p{h}x{w}", bgr, rng.random((h, w)) < 0.3))
    return photos


def test_padded_batch_filters_exactly_as_each_photo_alone():
    rng = np.random.default_rng(3)
    photos = _photos(rng, [(17, 23), (30, 12), (30, 31)])
    batch = pad_photos(photos, (30, 31))
    for i, p in enumerate(photos):
        h, w = p.truth.shape
        np.testing.assert_array_equal(batch.rgb[i, :h, :w], p.bgr[..., ::-1])
        np.testing.assert_array_equal(batch.truth[i, :h, :w], p.truth)
        assert not batch.truth[i][~batch.valid[i]].any() and batch.valid[i].sum() == h * w
    raw = rng.random((3, 30, 31)) < 0.5
    raw = np.asarray(methods.replicate_edges(raw, batch.rows, batch.cols))  # as a per-pixel rule on padded photos
    out = np.asarray(methods.filtered(raw, batch.rows, batch.cols))
    for i, p in enumerate(photos):
        h, w = p.truth.shape
        np.testing.assert_array_equal(out[i, :h, :w], np.asarray(median3(raw[i:i + 1, :h, :w], 3))[0])


def test_our_batched_masks_equal_hog_jax_segment():
    rng = np.random.default_rng(4)
    skin = rng.normal([200, 140, 110], 8, (2000, 3)).clip(0, 255)
    bg = rng.uniform(0, 255, (2000, 3))
    model = fit_skin_model(jax.random.key(0), skin, bg, n_components=2, n_background=2, n_iter=10)
    photos = _photos(rng, [(20, 26), (24, 18)])
    batch = pad_photos(photos, (24, 26))
    ours = np.asarray(methods.ours_masks(skin_log_ratio(model, batch.rgb), np.float32(0.5), batch.rows, batch.cols))
    for i, p in enumerate(photos):
        h, w = p.truth.shape
        reference = np.asarray(segment(model, p.bgr[None, ..., ::-1], threshold=0.5).skin)[0]
        np.testing.assert_array_equal(ours[i, :h, :w], reference)


def test_grabcut_keeps_a_seed_of_one_label():
    bgr = np.zeros((8, 8, 3), np.uint8)
    for seed in (np.zeros((8, 8), bool), np.ones((8, 8), bool)):
        mask, ran = methods.grabcut(bgr, seed, 1)
        assert not ran and np.array_equal(mask, seed)


def test_missing_data_exits_with_one_line(tmp_path):
    assert "real data not found" in missing_data(tmp_path)
    with pytest.raises(SystemExit, match="skin_real: real data not found") as exit_info:
        main(["--data", str(tmp_path), "--out", str(tmp_path / "run")])
    assert "\n" not in str(exit_info.value)


def test_study_smoke_on_three_real_photos(tmp_path):
    if missing_data(DATA):
        pytest.skip(f"real data absent: {DATA} (skin_nonskin_uci.tsv and hgr_hands/; see ../shared/data/README.md)")
    out = tmp_path / "run"
    written = main(["--data", str(DATA), "--preset", "quick", "--n-photos", "3", "--n-iter", "10",
                    "--grabcut-iterations", "1", "--batch-size", "2", "--sheet-photos", "2", "--out", str(out)])
    assert json.loads((out / "metrics.json").read_text()) == written
    for key in ("iou_ours", "iou_ycrcb", "iou_grabcut", "precision_ours", "recall_ours", "hand_found_rate_ours"):
        assert 0.0 <= written[key] <= 1.0, key
    assert written["n_photos"] == 3 and written["threshold_source"] == "uci_validation"
    assert written["iou_ours"] > 0.5  # a broken model or a swapped colour order scores far lower
    for name in ("report.md", "contact_sheet.png", "precision_recall.png", "per_photo.csv"):
        assert (out / name).stat().st_size > 0, name
    assert len((out / "per_photo.csv").read_text().splitlines()) == 4
