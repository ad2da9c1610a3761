"""The PHMM table-top experiment: its pieces against brute-force references, and a smoke run on tiny sizes."""
import json
import types

import numpy as np
import pytest

from experiments import phmm_tabletop as E
from experiments.data import tabletop as tt


def _dtw_reference(a, b):
    """float64 DTW by the textbook recursion, tracking the path length of the chosen predecessor."""
    cost = np.mean(np.sum((a[:, None] - b[None]) ** 2, -1), -1)
    n, m = cost.shape
    acc = np.full((n + 1, m + 1), np.inf)
    steps = np.zeros((n + 1, m + 1))
    acc[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            options = [(acc[i - 1, j], steps[i - 1, j]), (acc[i - 1, j - 1], steps[i - 1, j - 1]),
                       (acc[i, j - 1], steps[i, j - 1])]
            best, k = min(options, key=lambda o: o[0])
            acc[i, j], steps[i, j] = best + cost[i - 1, j - 1], k + 1
    return np.sqrt(acc[n, m] / steps[n, m])


def test_dtw_matches_reference():
    rng = np.random.default_rng(0)
    a = np.cumsum(rng.normal(size=(3, 12, 7, 3)), axis=1)
    b = np.cumsum(rng.normal(size=(3, 12, 7, 3)), axis=1)
    got = np.asarray(E.dtw_rms(a, b))
    np.testing.assert_allclose(got, [_dtw_reference(x, y) for x, y in zip(a, b)], rtol=1e-4)
    # A time-warped copy has (almost) no error; a constant 3-cm offset of every marker gives 3 cm.
    t = np.linspace(0, 1, 40)
    path = np.stack([np.sin(2 * np.pi * t), np.cos(2 * np.pi * t), t], -1)
    warped = np.stack([np.sin(2 * np.pi * t**1.3), np.cos(2 * np.pi * t**1.3), t**1.3], -1)
    x = np.repeat(path[None, :, None], 7, 2)
    y = np.repeat(warped[None, :, None], 7, 2)
    no_warp = np.sqrt(np.mean(np.sum((x - y) ** 2, -1)))
    assert float(E.dtw_rms(x, y)[0]) < 0.3 * no_warp
    np.testing.assert_allclose(float(E.dtw_rms(x, x + 0.03 / np.sqrt(3))[0]), 0.03, rtol=1e-4)
    full = E.synthesis_error(x.reshape(1, 40, 21), (x + 0.01).reshape(1, 40, 21))
    np.testing.assert_allclose(full, [0.01 * np.sqrt(3)], rtol=1e-4)


def test_local_maxima_and_inner_mask():
    u = np.linspace(-1, 1, 21)
    bowl = -(u[:, None] ** 2 + u[None] ** 2)
    np.testing.assert_allclose(E.local_maxima(bowl), [0.0])
    egg = np.cos(3 * np.pi * u)[:, None] + np.cos(3 * np.pi * u)[None] + 0.01 * u[:, None]
    values = E.local_maxima(egg)
    assert len(values) == 9 and values[0] == egg.max() and np.all(np.diff(values) <= 0)
    mask = E.inner_mask(5, 7).reshape(5, 7)
    assert mask.sum() == 15 and not mask[0].any() and not mask[:, -1].any()


def test_phi_to_position_inverts_target_to_phi():
    import phmm_jax as P

    corners = tt.raster_targets(3, 3)
    targets = tt.raster_targets(5, 7).reshape(-1, 3)
    np.testing.assert_allclose(E.phi_to_position(corners, P.target_to_phi(corners, targets)), targets, atol=1e-5)


def test_diagnostic_features_by_hand():
    markers = np.zeros((1, 4, 7, 3))
    markers[0, :, 4:7, 2] = np.array([0.0, 0.5, 0.2, 0.9])[:, None]  # the last frame is padding
    rec = tt.Recordings(markers, np.array([3]), np.array([0]), np.zeros((1, 3)), 60.0, tt.MARKERS)
    height, reach, speed = E.diagnostic_features(rec)[0]
    assert height == pytest.approx(0.5) and reach == pytest.approx(0.5) and speed == pytest.approx(0.5 * 60)


def test_regression_baseline_recovers_an_affine_finger_map():
    """Movements whose index tip at the hold (the sample farthest from the start) is an affine map of
    the target: the baseline, fitted per action, returns the targets exactly; the frames around the hold
    carry other values so that a wrong hold frame would show."""
    rng = np.random.default_rng(0)
    targets = np.c_[rng.uniform(-0.3, 0.5, (40, 2)), np.full(40, tt.TABLE_HEIGHT_M)]
    action = np.arange(40) % 2
    A = np.array([[[0.9, 0.1, 0.0], [-0.2, 1.1, 0.3]], [[1.2, 0.0, 0.1], [0.1, 0.8, -0.4]]])  # (actions, 2, 3)
    markers = np.zeros((40, 5, 7, 3))
    markers[:, 1:, 4:7] = rng.normal(0, 0.01, (40, 4, 3, 3))
    markers[:, 2, 4:7] += 1.0  # the hold: the hand centre is farthest from its start here
    markers[:, 2, 5] = np.einsum("bij,bj->bi", A[action].transpose(0, 2, 1), targets[:, :2]) + [0.1, 0.2, 0.3]
    X = markers.reshape(40, 5, 21)
    np.testing.assert_allclose(E.final_markers(X), markers[:, 2, 5])
    train, test = slice(0, 30), slice(30, 40)
    pred = E.regression_baseline(X[train], targets[train], action[train], X[test], action[test])
    np.testing.assert_allclose(pred, targets[test], atol=1e-9)


def test_config_validation():
    with pytest.raises(ValueError, match="noise_cm"):
        E.Config(noise_cm=(5.0,))
    with pytest.raises(ValueError, match="test_rows"):
        E.Config(test_rows=2)


TINY = ["--train-repetitions", "2", "--test-repetitions", "1", "--test-rows", "3", "--test-cols", "3",
        "--n-states", "5", "--min-duration", "2", "--max-duration", "8", "--n-samples", "30", "--n-iter", "2",
        "--average-states", "8", "--noise-cm", "0,10", "--recognition-steps", "2"]


def test_smoke_run(tmp_path):
    metrics = E.main(TINY + ["--out", str(tmp_path)])
    saved = json.loads((tmp_path / "metrics.json").read_text())
    for key in ("synthesis_error_cm_inner", "synthesis_error_cm_all", "param_error_cm_inner", "param_error_cm_all",
                "classification_rate_phmm_2x2", "classification_rate_phmm_3x3", "classification_rate_hmm",
                "classification_rate_diagnostic_baseline", "n_test_sequences", "runtime_s",
                "robot_reach_error_cm_mean", "robot_reach_error_cm_max", "param_error_cm_regression_all",
                "param_error_cm_regression_hand_inner", "param_error_cm_noise_regression_10cm"):
        assert np.isfinite(saved[key]), key
    assert saved["n_test_sequences"] == 18
    for key in ("param_error_cm_noise", "param_error_cm_noise_2x2", "classification_rate_noise",
                "classification_rate_noise_2x2", "classification_rate_noise_hmm"):
        assert {f"{key}_0cm", f"{key}_10cm"} <= set(saved), key
    assert all(np.isscalar(v) for v in saved.values())  # flat keys, units in the names
    for key in ("classification_rate_phmm_2x2", "classification_rate_hmm", "classification_rate_diagnostic_baseline"):
        assert 0.0 <= saved[key] <= 1.0
    assert saved["robot_elbow_plane_distance_mm_max"] < 0.1  # the robot elbow stays in the human arm plane
    assert metrics["synthesis_error_cm_all"] == saved["synthesis_error_cm_all"]
    for name in ("report.md", "synthesis_error_maps.png", "param_error_maps.png", "classification_error_maps.png",
                 "loglik_surface.png", "noise_robustness.png", "robot_trajectories.png", "robot_frame.png"):
        assert (tmp_path / name).stat().st_size > 0, name


def test_demo_stage(tmp_path):
    from experiments.config import RunOutput

    result = E.demo_stage(types.SimpleNamespace(seed=1))
    metrics, section = result.metrics, result.report
    RunOutput(tmp_path, "demo").write(metrics, section, result.figures)
    assert (tmp_path / "phmm_demo.png").stat().st_size > 0
    assert metrics["phmm_demo_action_recognised"] in tt.ACTIONS
    assert np.isfinite(metrics["phmm_demo_target_error_cm"]) and "phmm_demo.png" in section
