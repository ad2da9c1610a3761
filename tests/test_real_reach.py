"""The real-reach study (`experiments.real_reach`) end to end on a tiny synthetic reach npz, and its
skip without data."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from experiments.real_reach import METHODS, Config, main
from experiments.real_reach import events as evt
from experiments.real_reach.data import event_features, load_movements, reach_features
from experiments.real_reach.methods import dtw_distances, nearest_class_mean, standardise_per_person

JOINTS = ("Neck", "RShoulder", "RElbow", "RWrist", "MidHip", "RPalmBase", "RThumb4FingerTip", "RIndex4FingerTip",
          "RMiddle1Knuckles", "RMiddle4FingerTip")
SIZES = {"S": 2.5, "M": 5.5, "L": 7.5}


def write_reach_npz(path: Path, n_persons: int = 3, per_size: int = 3) -> Path:
    """Movements in the layout of reach_grasp_openpose_p1-4.npz: rest, a reach whose grip opens with
    the cube's size, then a lift; each person with its own body scale and resting pose."""
    rng = np.random.default_rng(0)
    names, participant, size, size_cm, offsets, t, xy, prob, onset, end = [], [], [], [], [0], [], [], [], [], []
    for p in range(1, n_persons + 1):
        scale, origin = 1.0 + 0.15 * p, np.array([300.0 + 20 * p, 400.0])
        for s, cm in SIZES.items():
            for k in range(per_size):
                rest, reach, after = int(rng.integers(12, 18)), int(rng.integers(18, 24)), 15
                n = rest + reach + after
                u = np.clip((np.arange(n) - rest) / reach, 0, 1)
                smooth = u * u * (3 - 2 * u)
                wrist = origin + scale * np.outer(smooth, [120.0, -80.0])
                aperture = scale * (8 + 4 * cm * np.sin(np.pi * np.clip(u, 0, 1)) + 1.5 * cm * (u >= 1))
                frame = np.zeros((n, len(JOINTS), 2))
                frame[:, 0] = origin + scale * np.array([-60.0, -150.0])
                frame[:, 1] = frame[:, 0] + scale * np.array([-40.0, 0.0])
                frame[:, 2] = (frame[:, 1] + wrist) / 2
                frame[:, 3] = wrist
                frame[:, 4] = origin + scale * np.array([-60.0, 50.0])
                frame[:, 5] = wrist + scale * np.array([5.0, 0.0])
                frame[:, 6] = wrist + np.column_stack([np.full(n, 10.0), -aperture / 2])
                frame[:, 7] = wrist + np.column_stack([np.full(n, 10.0), aperture / 2])
                frame[:, 8] = wrist + scale * np.array([15.0, 0.0])
                frame[:, 9] = wrist + np.column_stack([np.full(n, 12.0), aperture / 2 + 3 * scale])
                frame += rng.normal(0, 0.7, frame.shape)
                times = np.arange(n) / 60.0
                names.append(f"P{p}_{s}_{k + 1:02d}")
                participant.append(p), size.append(s), size_cm.append(cm)
                onset.append(times[rest]), end.append(times[rest + reach - 1])
                offsets.append(offsets[-1] + n)
                t.append(times), xy.append(np.round(10 * frame)), prob.append(np.full((n, len(JOINTS)), 0.8))
    np.savez_compressed(path, names=np.array(names), participant=np.array(participant, np.int8), size=np.array(size),
                        size_cm=np.array(size_cm, np.float32), offsets=np.array(offsets),
                        t=np.concatenate(t).astype(np.float32), xy_dpx=np.concatenate(xy).astype(np.uint16),
                        prob=np.concatenate(prob).astype(np.float16), joints=np.array(JOINTS),
                        rtg_onset=np.array(onset, np.float32), rtg_end=np.array(end, np.float32))
    return path


def test_quick_preset_on_a_synthetic_reach_npz(tmp_path):
    data = write_reach_npz(tmp_path / "reach.npz")
    movements = load_movements(data)
    assert len(movements) == 27 and {m.person for m in movements} == {1, 2, 3}
    features = reach_features(movements[0], "person")
    assert features.shape[1] == 10 and np.allclose(features[0, :2], 0.0)  # the wrist from its onset position
    out = tmp_path / "run"
    written = main(["--preset", "quick", "--data", str(data), "--out", str(out), "--n-iter", "3",
                    "--fractions", "0.5,1.0", "--event-lags", "2", "--n-phi", "3", "--search", "false"])
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["skipped"] is False and written["person_n_test_reaches"] == 27
    for norm in ("person", "pixels", "calibrated"):
        for method in METHODS:
            assert 0.0 <= metrics[f"{norm}_accuracy_{method}"] <= 1.0
            assert 0.0 <= metrics[f"{norm}_accuracy_50pct_{method}"] <= 1.0
        assert (out / f"accuracy_vs_reach_{norm}.png").is_file() and (out / f"confusion_{norm}.png").is_file()
    # the grip opens with the size: the aperture rule finds it on new persons in the person units
    assert metrics["person_accuracy_aperture"] > 0.8
    # onset and contact of noise-light synthetic streams are found within a few frames
    assert metrics["onset_median_abs_error_frames_speed"] <= 3
    assert metrics["onset_median_abs_error_frames_hmm_lag_2"] <= 3
    assert (out / "event_errors.png").is_file() and "## Reach onset and contact" in (out / "report.md").read_text()


def test_skips_without_data(tmp_path, capsys):
    written = main(["--data", str(tmp_path / "absent"), "--out", str(tmp_path / "run")])
    assert written["skipped"] is True and "skipped" in capsys.readouterr().err


def test_config_checks_its_fields():
    with pytest.raises(ValueError, match="fractions"):
        Config(fractions=(0.5,))
    with pytest.raises(ValueError, match="normalisations"):
        Config(normalisations=("metres",))


def _dtw_reference(a: np.ndarray, b: np.ndarray) -> float:
    """The textbook DTW recursion, frame by frame in float64."""
    table = np.full((len(a) + 1, len(b) + 1), np.inf)
    table[0, 0] = 0.0
    for i in range(1, len(a) + 1):
        for j in range(1, len(b) + 1):
            table[i, j] = np.sum((a[i - 1] - b[j - 1]) ** 2) + min(table[i - 1, j], table[i - 1, j - 1], table[i, j - 1])
    return float(np.sqrt(table[-1, -1]))


def test_dtw_distances_match_the_recursion():
    rng = np.random.default_rng(1)
    refs = [rng.normal(size=(int(n), 3)) for n in rng.integers(2, 9, size=6)]
    query = rng.normal(size=(5, 3))
    np.testing.assert_allclose(dtw_distances(query, refs), [_dtw_reference(query, r) for r in refs], rtol=1e-12)
    assert dtw_distances(refs[0], refs[:1])[0] == 0.0


def test_class_means_and_per_person_scores_match_references():
    from scipy.stats import zscore
    from sklearn.neighbors import NearestCentroid

    rng = np.random.default_rng(2)
    x, y = rng.normal(size=(40, 2)) + np.repeat(np.arange(3), [14, 13, 13])[:, None], np.repeat(np.arange(3), [14, 13, 13])
    test = rng.normal(size=(25, 2)) * 2
    np.testing.assert_array_equal(nearest_class_mean(x, y, test), NearestCentroid().fit(x, y).predict(test))
    # a class absent from the training rows is never chosen
    assert set(nearest_class_mean(x[y != 1], y[y != 1], test).tolist()) <= {0, 2}
    persons = rng.integers(1, 4, size=40)
    z = standardise_per_person(x, persons)
    for p in (1, 2, 3):
        np.testing.assert_allclose(z[persons == p], zscore(x[persons == p], axis=0), rtol=1e-12)


def test_event_detectors_are_online_and_find_known_boundaries(tmp_path):
    # fitted on two persons, run on the third; the synthetic reaches' onset and contact are known
    movements = load_movements(write_reach_npz(tmp_path / "reach.npz"))
    feats = [event_features(m) for m in movements]
    onsets, contacts = np.array([m.onset for m in movements]), np.array([m.contact for m in movements])
    train = np.array([m.person for m in movements]) != 3
    cfg = Config()
    tr = [f for f, k in zip(feats, train) if k]
    test = [f for f, k in zip(feats, train) if not k]
    speed = evt.fit_speed(tr, onsets[train], contacts[train], cfg)
    found = {"speed": (speed, evt.detect_speed(speed, test, cfg))}
    hmm = evt.fit_event_hmm(tr, onsets[train], contacts[train], cfg)
    found["hmm"] = (hmm, evt.detect_hmm(hmm, test, 2))
    for name, (model, e) in found.items():
        assert np.median(np.abs(e.onset - onsets[~train])) <= 2, name
        assert np.median(np.abs(e.contact - contacts[~train])) <= 3, name
        # online: each estimate is the same from the stream cut at the frame it was known
        for k, F in enumerate(test):
            for event in ("onset", "contact"):
                known = int(getattr(e, f"{event}_known")[k])
                cut = (evt.detect_speed(model, [F[:known + 1]], cfg) if name == "speed"
                       else evt.detect_hmm(model, [F[:known + 1]], 2))
                assert getattr(cut, event)[0] == getattr(e, event)[k], (name, event, k)
