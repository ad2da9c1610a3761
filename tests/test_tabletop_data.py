"""The simulated table-top motion capture (experiments.data.tabletop) and the loader for real recordings."""
import numpy as np
import pytest

from experiments.data import reaching
from experiments.data import tabletop as tt


@pytest.fixture(scope="module")
def subject():
    return tt.sample_subject(np.random.default_rng(3))


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    subjects = [tt.sample_subject(rng)]
    targets = tt.raster_targets(3, 3).reshape(-1, 3)
    return tt.concatenate([tt.simulate(rng, subjects, targets, 2, a) for a in tt.ACTIONS])


def _valid_frames(rec, b):
    return rec.markers[b, :rec.lengths[b]]


def test_raster_covers_80_by_30_cm():
    r = tt.raster_targets(5, 7)
    assert r.shape == (5, 7, 3)
    assert np.allclose(r[..., 0].max() - r[..., 0].min(), 0.8)
    assert np.allclose(r[..., 1].max() - r[..., 1].min(), 0.3)
    assert np.allclose(r[..., 2], tt.TABLE_HEIGHT_M)
    assert np.allclose(np.diff(r[0, :, 0]), 0.8 / 6) and np.allclose(np.diff(r[:, 0, 1]), 0.3 / 4)


def test_format_timing_and_determinism(subject):
    a = tt.simulate_movement(np.random.default_rng(5), subject, [0.1, 0.4, tt.TABLE_HEIGHT_M], "pointing")
    b = tt.simulate_movement(np.random.default_rng(5), subject, [0.1, 0.4, tt.TABLE_HEIGHT_M], "pointing")
    np.testing.assert_array_equal(a, b)
    assert a.ndim == 3 and a.shape[1:] == (7, 3) and np.all(np.isfinite(a))
    assert 1.5 * tt.FRAME_RATE_HZ < a.shape[0] < 4.5 * tt.FRAME_RATE_HZ  # 60 Hz, a few seconds


@pytest.mark.parametrize("action", tt.ACTIONS)
def test_rigid_segments(subject, action):
    """Without marker noise and occlusions, upper arm, forearm and wrist-knuckle lengths are the
    subject's, in every frame."""
    rng = np.random.default_rng(11)
    for target in tt.raster_targets(2, 2).reshape(-1, 3):
        x = tt.simulate_movement(rng, subject, target, action, marker_noise_m=0.0, drop_rate=0.0)
        for (i, j), length in (((1, 2), subject.upper_arm), ((2, 3), subject.forearm)):
            np.testing.assert_allclose(np.linalg.norm(x[:, i] - x[:, j], axis=-1), length, rtol=1e-9)
        knuckle = np.linalg.norm(x[:, 4] - x[:, 3], axis=-1)
        np.testing.assert_allclose(knuckle, np.hypot(subject.hand, 0.015), rtol=1e-9)


def test_start_and_end_in_the_base_pose(data):
    """Both actions start and end with the hand hanging beside the hip, below the table top."""
    for b in range(len(data.lengths)):
        hand = _valid_frames(data, b)[:, 4:7].mean(1)
        assert np.linalg.norm(hand[0] - hand[-1]) < 0.03
        assert hand[0, 2] < tt.TABLE_HEIGHT_M - 0.1 and hand[0, 1] < tt.TABLE_EDGE_Y


def test_reaching_touches_and_pointing_points(data):
    for b in range(len(data.lengths)):
        x = _valid_frames(data, b)
        hand = x[:, 4:7].mean(1)
        target = data.target[b]
        closest = np.argmin(np.linalg.norm(hand - target, axis=-1))
        distance = np.linalg.norm(hand[closest] - target)
        if tt.ACTIONS[data.action[b]] == "reaching":
            assert distance < 0.12  # object height (3-7 cm) + end-point scatter
            assert hand[closest, 2] > tt.TABLE_HEIGHT_M
        else:
            assert distance > 0.1  # points from a distance
            hold = len(x) // 2
            finger = x[hold, 5] - x[hold, 4]
            to_target = target - x[hold, 4]
            cos = finger @ to_target / np.linalg.norm(finger) / np.linalg.norm(to_target)
            assert cos > np.cos(np.deg2rad(25.0))  # the index finger points at the target


def test_arm_stays_out_of_the_table(data):
    assert tt.table_penetration(data).max() < 0.01


def test_fill_gaps_matches_interpolation():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(20, 7, 3))
    holes = x.copy()
    holes[3:6, 2] = np.nan
    holes[0:2, 4] = np.nan
    filled = tt.fill_gaps(holes)
    t = np.arange(20)
    for k in range(3):
        np.testing.assert_allclose(filled[:, 2, k], np.interp(t, np.r_[t[:3], t[6:]], np.r_[x[:3, 2, k], x[6:, 2, k]]))
    np.testing.assert_allclose(filled[:2, 4], np.broadcast_to(x[2, 4], (2, 3)))
    np.testing.assert_array_equal(filled[:, 0], x[:, 0])
    holes[:, 1] = np.nan
    with pytest.raises(ValueError, match="marker 1"):
        tt.fill_gaps(holes)


def test_resample_against_numpy_interp(data):
    out = tt.resample(data, 37)
    assert out.shape == (len(data.lengths), 37, 21)
    b = 3
    n = data.lengths[b]
    ref = np.interp(np.linspace(0, n - 1, 37), np.arange(n), data.markers[b, :n, 5, 1])
    np.testing.assert_allclose(out[b, :, 5 * 3 + 1], ref, atol=1e-12)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_loader_round_trip(tmp_path, subject, suffix):
    x = tt.simulate_movement(np.random.default_rng(2), subject, [0.0, 0.3, tt.TABLE_HEIGHT_M], "reaching")
    x[10:13, 3] = np.nan  # an occlusion
    path = tt.save_recording(tmp_path / f"rec{suffix}", x, "reaching", [0.0, 0.3, tt.TABLE_HEIGHT_M])
    rec = tt.load_recording(path)
    assert rec.markers.shape == (1,) + x.shape and rec.lengths[0] == len(x)
    assert rec.action[0] == tt.ACTIONS.index("reaching") and rec.frame_rate == tt.FRAME_RATE_HZ
    np.testing.assert_allclose(rec.markers[0], tt.fill_gaps(x), atol=1e-12)
    np.testing.assert_allclose(rec.target[0], [0.0, 0.3, tt.TABLE_HEIGHT_M])


def test_loader_reorders_markers_and_rejects_bad_files(tmp_path):
    x = np.random.default_rng(0).normal(size=(5, 7, 3))
    order = [6, 0, 3, 1, 5, 2, 4]
    np.savez(tmp_path / "shuffled.npz", markers=x[:, order], marker_names=np.array(tt.MARKERS)[order],
             frame_rate=60.0, action="pointing", target=np.zeros(3))
    np.testing.assert_allclose(tt.load_recording(tmp_path / "shuffled.npz").markers[0], x)
    np.savez(tmp_path / "missing.npz", markers=x[:, :6], marker_names=np.array(tt.MARKERS[:6]),
             frame_rate=60.0, action="pointing", target=np.zeros(3))
    with pytest.raises(ValueError, match="marker_names"):
        tt.load_recording(tmp_path / "missing.npz")
    np.savez(tmp_path / "action.npz", markers=x, marker_names=np.array(tt.MARKERS), frame_rate=60.0,
             action="waving", target=np.zeros(3))
    with pytest.raises(ValueError, match="action"):
        tt.load_recording(tmp_path / "action.npz")
    (tmp_path / "x.txt").write_text("1")
    with pytest.raises(ValueError, match="path"):
        tt.load_recording(tmp_path / "x.txt")
    (tmp_path / "bad.csv").write_text("# frame_rate: 60\nsternum_x,sternum_y,sternum_z\n1,2,3\n")
    with pytest.raises(ValueError, match="path"):
        tt.load_recording(tmp_path / "bad.csv")


def test_protocol_sizes_and_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LFD_JAX_CACHE", str(tmp_path))
    train, test = tt.protocol_data(7, (3, 3), 2, (3, 3), 1)
    assert len(train.lengths) == 2 * 9 * 2 and len(test.lengths) == 2 * 9
    again = tt.protocol_data(7, (3, 3), 2, (3, 3), 1)[1]
    np.testing.assert_array_equal(again.markers, test.markers)
    assert list(tmp_path.glob("phmm_tabletop/*.npz"))


def test_bench_view_shapes():
    out = reaching.movements_at(np.random.default_rng(0), reaching.raster_targets(2, 2).reshape(-1, 3), 2,
                                "pointing", 50)
    assert out.shape == (4, 2, 50, 21) and np.all(np.isfinite(out))
    with pytest.raises(ValueError, match="kind"):
        reaching.movements_at(np.random.default_rng(0), np.zeros((1, 3)), 1, "waving")
