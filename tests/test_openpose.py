"""The OpenPose / reach-to-grasp keypoint readers (`lfd_jax.load_openpose_folder`, `load_reach_npz`,
`load_reach_csv`), gap filling of keypoint tracks, and `lfd-jax phmm fit / recognize` on them."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfd_jax import (BODY_25, HAND_21, KeypointTracks, crop_to_reach, drop_untracked_keypoints, fill_track_gaps,
                     load_openpose_folder, load_reach_csv, load_reach_npz, make_tracks, read_openpose_frame,
                     select_keypoints)

ROOT = Path(__file__).resolve().parents[1]
REACH_NPZ = ROOT.parent / "shared" / "data" / "reach_grasp" / "reach_grasp_openpose_p1-4.npz"
NECK = BODY_25.index("Neck")


def person(centre, conf=0.9, *, hand_left=True, hand_right=True, rng=None) -> dict:
    """One OpenPose person: BODY_25 around `centre` (neck at it), hands at offsets, confidence `conf`."""
    rng = rng or np.random.default_rng(0)
    pose = np.column_stack([centre[0] + 5 * np.arange(25), centre[1] + 3 * np.arange(25), np.full(25, conf)])
    hand = np.column_stack([centre[0] + 40 + np.arange(21), centre[1] + 60 + np.arange(21), np.full(21, conf)])
    return {"person_id": [-1], "pose_keypoints_2d": pose.ravel().tolist(),
            "hand_left_keypoints_2d": hand.ravel().tolist() if hand_left else [],
            "hand_right_keypoints_2d": (hand + [10, 0, 0]).ravel().tolist() if hand_right else [],
            "face_keypoints_2d": []}


def write_frames(folder: Path, frames: list[list[dict]], numbers=None, video="clip") -> Path:
    """folder/<video>_<12-digit frame>_keypoints.json, one per frame, as OpenPose --write_json does."""
    folder.mkdir(parents=True, exist_ok=True)
    for k, people in zip(numbers if numbers is not None else range(len(frames)), frames):
        (folder / f"{video}_{k:012d}_keypoints.json").write_text(json.dumps({"version": 1.3, "people": people}))
    return folder


def test_misses_become_nan_and_confidences_are_kept(tmp_path):
    frames = [[person((100.0 + t, 200.0))] for t in range(6)]
    pose = np.array(frames[2][0]["pose_keypoints_2d"]).reshape(25, 3)
    pose[NECK] = 0.0                             # OpenPose's miss: x = y = c = 0
    pose[BODY_25.index("RWrist"), 2] = 0.0       # c = 0 alone is a miss too
    frames[2][0]["pose_keypoints_2d"] = pose.ravel().tolist()
    tracks = load_openpose_folder(write_frames(tmp_path / "v", frames), rate_hz=25.0)
    assert isinstance(tracks, KeypointTracks)
    assert tracks.xy.shape == (6, 25 + 42, 2) and tracks.confidence.shape == (6, 67)
    assert tracks.names[:25] == BODY_25 and tracks.names[25] == "LPalmBase" and tracks.names[-1] == "RPinky4FingerTip"
    missed = np.isnan(tracks.xy).any(-1)
    assert missed.sum() == 2 and missed[2, NECK] and missed[2, BODY_25.index("RWrist")]
    assert tracks.confidence[2, NECK] == 0 and tracks.confidence[3, NECK] == pytest.approx(0.9)
    np.testing.assert_allclose(tracks.xy[4, NECK], [104.0 + 5 * NECK, 200.0 + 3 * NECK])
    np.testing.assert_allclose(tracks.time_s, np.arange(6) / 25.0)
    low = load_openpose_folder(tmp_path / "v", rate_hz=25.0, min_confidence=0.95)
    assert np.isnan(low.xy).all()


def test_two_people_the_followed_one_is_kept(tmp_path):
    """Person A (most confident in frame 0) walks right; B stands still; their order in the file swaps."""
    frames = []
    for t in range(8):
        a, b = person((100.0 + 10 * t, 100.0), 0.9), person((400.0, 300.0), 0.6)
        frames.append([a, b] if t % 2 == 0 else [b, a])
    frames[3] = [person((400.0, 300.0), 0.6)]    # A not detected in frame 3: B is the only one there
    frames[5] = [person((1000.0, 1000.0), 0.95)]  # ... and a third, far away, in frame 5
    tracks = load_openpose_folder(write_frames(tmp_path / "v", frames), rate_hz=30.0)
    neck_x = tracks.xy[:, NECK, 0]
    expected = 100.0 + 5 * NECK + 10 * np.arange(8)
    keep = (np.arange(8) != 3) & (np.arange(8) != 5)
    np.testing.assert_allclose(neck_x[keep], expected[keep])
    assert np.isnan(tracks.xy[[3, 5]]).all()     # A missed there, not swapped for B
    second = load_openpose_folder(tmp_path / "v", rate_hz=30.0, person=1)
    assert np.isnan(second.xy[3]).all()          # frame 3 has one person only
    np.testing.assert_allclose(second.xy[[0, 2], NECK, 0], [405.0, 405.0])
    np.testing.assert_allclose(second.xy[[1, 7], NECK, 0], [115.0, 175.0])


def test_missing_hand_is_nan(tmp_path):
    frames = [[person((100.0, 100.0))] for _ in range(5)]
    frames[1] = [person((100.0, 100.0), hand_left=False)]             # empty list: hand not detected / not run
    zero = person((100.0, 100.0))
    zero["hand_right_keypoints_2d"] = [0.0] * 63                      # all zeros: hand not detected
    frames[3] = [zero]
    tracks = load_openpose_folder(write_frames(tmp_path / "v", frames), rate_hz=30.0)
    left = [tracks.names.index("L" + n) for n in HAND_21]
    right = [tracks.names.index("R" + n) for n in HAND_21]
    missed = np.isnan(tracks.xy).any(-1)
    assert missed[1, left].all() and not missed[1, right].any()
    assert missed[3, right].all() and not missed[3, left].any()
    assert missed.sum() == 42
    body = load_openpose_folder(tmp_path / "v", rate_hz=30.0, parts=("pose",))
    assert body.names == BODY_25 and np.isfinite(body.xy).all()
    none = [[person((1.0, 1.0), hand_left=False, hand_right=False)] for _ in range(3)]
    untracked = load_openpose_folder(write_frames(tmp_path / "w", none), rate_hz=30.0)
    assert drop_untracked_keypoints(untracked).names == BODY_25


def test_absent_frame_numbers_are_missed_frames(tmp_path):
    frames = [[person((100.0, 100.0))] for _ in range(3)]
    tracks = load_openpose_folder(write_frames(tmp_path / "v", frames, numbers=[5, 6, 9]), rate_hz=30.0)
    assert len(tracks.xy) == 5 and np.isnan(tracks.xy[2:4]).all() and np.isfinite(tracks.xy[[0, 1, 4]]).all()


def test_gap_filling_up_to_the_limit(tmp_path):
    T = 12
    frames = [[person((100.0 + 7.0 * t, 50.0 + 2.0 * t ** 1.5))] for t in range(T)]
    for t in (4, 5, 6):
        frames[t][0]["pose_keypoints_2d"][3 * NECK: 3 * NECK + 3] = [0.0, 0.0, 0.0]
    tracks = select_keypoints(load_openpose_folder(write_frames(tmp_path / "v", frames), rate_hz=30.0),
                              ["Neck", "RWrist"])
    filled = fill_track_gaps(tracks, max_gap_frames=3)
    seen = np.ones(T, bool)
    seen[4:7] = False
    for k in range(2):                            # the reference: numpy.interp over the seen frames
        np.testing.assert_allclose(filled.xy[:, 0, k], np.interp(np.arange(T), np.flatnonzero(seen),
                                                                 tracks.xy[seen, 0, k]))
    np.testing.assert_array_equal(filled.xy[:, 1], tracks.xy[:, 1])
    assert (filled.confidence[4:7, 0] == 0).all()             # filled frames keep confidence 0
    np.testing.assert_allclose(fill_track_gaps(tracks, max_gap_s=0.1).xy, filled.xy)   # 0.1 s = 3 frames at 30 Hz
    with pytest.raises(ValueError, match="keypoint 'Neck' has a gap longer than 2 frames .*4-6"):
        fill_track_gaps(tracks, max_gap_frames=2)


def test_malformed_files_name_their_path(tmp_path):
    folder = write_frames(tmp_path / "v", [[person((1.0, 1.0))] for _ in range(3)])
    bad = folder / "clip_000000000001_keypoints.json"
    bad.write_text('{"version": 1.3, "people": [')
    with pytest.raises(ValueError, match=f"path: {bad}"):
        load_openpose_folder(folder, rate_hz=30.0)
    bad.write_text(json.dumps({"version": 1.3, "people": [{"pose_keypoints_2d": [1.0, 2.0]}]}))
    with pytest.raises(ValueError, match=f"path: {bad}.*3 per keypoint"):
        load_openpose_folder(folder, rate_hz=30.0)
    bad.write_text(json.dumps({"version": 1.3, "people": [{"pose_keypoints_2d": [1.0, 2.0, 0.5] * 25,
                                                           "hand_left_keypoints_2d": [1.0] * 60}]}))
    with pytest.raises(ValueError, match=f"path: {bad}.*hand_left"):
        load_openpose_folder(folder, rate_hz=30.0)
    bad.write_text(json.dumps({"version": 1.3}))
    with pytest.raises(ValueError, match=f"path: {bad}.*people"):
        read_openpose_frame(bad)
    bad.write_text(json.dumps({"version": 1.3, "people": [{"pose_keypoints_2d": [1.0, 2.0, 0.5] * 18}]}))
    with pytest.raises(ValueError, match="18 pose keypoints"):
        load_openpose_folder(folder, rate_hz=30.0)
    write_frames(folder, [[person((1.0, 1.0))]], video="other")
    with pytest.raises(ValueError, match="several videos"):
        load_openpose_folder(folder, rate_hz=30.0)
    with pytest.raises(ValueError, match="path: no such folder"):
        load_openpose_folder(tmp_path / "absent", rate_hz=30.0)
    with pytest.raises(ValueError, match="no \\*_keypoints.json"):
        load_openpose_folder(tmp_path, rate_hz=30.0)
    with pytest.raises(ValueError, match="rate_hz"):
        load_openpose_folder(folder, rate_hz=0.0)
    with pytest.raises(ValueError, match="parts"):
        load_openpose_folder(folder, rate_hz=30.0, parts=("feet",))


@settings(max_examples=15, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 4000), st.integers(1, 4000), st.sampled_from([0.0, 0.05, 0.5, 1.0])),
                min_size=25, max_size=25), st.data())
def test_json_round_trip_property(tmp_path_factory, pose, data):
    """Whatever the keypoints, the reader gives NaN exactly where c = 0 and the written values elsewhere."""
    pose = np.array(pose, float)
    folder = tmp_path_factory.mktemp("prop")
    write_frames(folder, [[{"pose_keypoints_2d": pose.ravel().tolist()}]])
    tracks = load_openpose_folder(folder, rate_hz=30.0, parts=("pose",))
    missed = pose[:, 2] == 0
    np.testing.assert_array_equal(np.isnan(tracks.xy[0]).any(-1), missed)
    np.testing.assert_array_equal(tracks.xy[0, ~missed], pose[~missed, :2])
    np.testing.assert_array_equal(tracks.confidence[0], pose[:, 2])


def write_reach_npz(path: Path) -> Path:
    """Two movements in the layout of reach_grasp_openpose_p1-4.npz: 5 and 4 frames, 3 joints."""
    rng = np.random.default_rng(2)
    xy = rng.integers(100, 60000, size=(9, 3, 2)).astype(np.uint16)
    prob = rng.uniform(0.2, 1.0, size=(9, 3)).astype(np.float16)
    xy[2, 1], prob[2, 1] = 0, 0.0                   # a miss in movement 0, frame 2, joint RWrist
    t = np.concatenate([np.arange(5) / 60.0, np.arange(4) / 60.0]).astype(np.float32)
    np.savez_compressed(path, names=np.array(["P1_S_01", "P2_L_03"]), participant=np.array([1, 2], np.int8),
                        size=np.array(["S", "L"]), size_cm=np.array([2.5, 7.5], np.float32),
                        offsets=np.array([0, 5, 9]), t=t, xy_dpx=xy, prob=prob,
                        joints=np.array(["Neck", "RWrist", "RPalmBase"]),
                        rtg_onset=np.array([t[1], t[5]], np.float32), rtg_end=np.array([t[3], t[6]], np.float32))
    return path


def test_reach_npz_reader(tmp_path):
    path = write_reach_npz(tmp_path / "reach.npz")
    movements = load_reach_npz(path)
    assert [m.name for m in movements] == ["P1_S_01", "P2_L_03"]
    first = movements[0]
    assert (first.participant, first.size, first.size_cm) == (1, "S", 2.5)
    assert first.tracks.xy.shape == (5, 3, 2) and first.tracks.names == ("Neck", "RWrist", "RPalmBase")
    with np.load(path) as raw:
        xy, prob = raw["xy_dpx"][:5].astype(float) / 10.0, raw["prob"][:5].astype(float)
    xy[2, 1] = np.nan
    np.testing.assert_allclose(first.tracks.xy, xy)
    np.testing.assert_allclose(first.tracks.confidence, prob)
    assert first.tracks.rate_hz == pytest.approx(60.0, rel=1e-4)
    cropped = crop_to_reach(first)
    assert len(cropped.xy) == 3 and cropped.time_s[0] == pytest.approx(1 / 60.0)
    assert [m.name for m in load_reach_npz(path, "_L_")] == ["P2_L_03"]
    assert [m.name for m in load_reach_npz(path, ["P2_L_03", "P1_S_01"])] == ["P2_L_03", "P1_S_01"]
    with pytest.raises(ValueError, match="movements"):
        load_reach_npz(path, "P9")
    np.savez(tmp_path / "other.npz", names=np.array(["a"]))
    with pytest.raises(ValueError, match=f"path: {tmp_path / 'other.npz'} lacks"):
        load_reach_npz(tmp_path / "other.npz")


def test_reach_csv_reader(tmp_path):
    path = tmp_path / "P1_M_02.csv"
    path.write_text("Neck.x,Neck.y,Neck.prob,RWrist.x,RWrist.y,RWrist.prob,Time\n"
                    "10.5,20,0.9,30,40,0.8,0\n10.5,20,0.9,0,0,0,0.0166\n11,21,0.7,31,41,0.6,0.0333\n")
    tracks = load_reach_csv(path)
    assert tracks.names == ("Neck", "RWrist") and tracks.xy.shape == (3, 2, 2)
    assert np.isnan(tracks.xy[1, 1]).all() and tracks.confidence[1, 1] == 0
    assert tracks.xy[2, 0].tolist() == [11.0, 21.0] and tracks.rate_hz == pytest.approx(60.0, rel=0.01)
    path.write_text("Neck.x,Neck.y,Time\n1,2,0\n")
    with pytest.raises(ValueError, match=f"path: {path}"):
        load_reach_csv(path)


def test_make_tracks_checks_its_arguments():
    with pytest.raises(ValueError, match="names"):
        make_tracks(np.zeros((2, 2, 2)), np.ones((2, 2)), ["a", "a"], 30.0)
    with pytest.raises(ValueError, match="confidence"):
        make_tracks(np.zeros((2, 2, 2)), np.ones((2, 3)), ["a", "b"], 30.0)
    with pytest.raises(ValueError, match="xy"):
        make_tracks(np.full((2, 2, 2), np.inf), np.ones((2, 2)), ["a", "b"], 30.0)


@pytest.mark.skipif(not REACH_NPZ.is_file(), reason="the real reach data (../shared/data/reach_grasp) is absent")
def test_real_reach_npz():
    movements = load_reach_npz(REACH_NPZ)
    assert len(movements) == 358
    assert {m.participant for m in movements} == {1, 2, 3, 4} and {m.size for m in movements} == {"S", "M", "L"}
    assert all(m.tracks.xy.shape[1:] == (26, 2) and m.tracks.confidence.shape[1] == 26 for m in movements)
    assert sum(len(m.tracks.xy) for m in movements) == 132002
    assert movements[0].tracks.names[:4] == ("Neck", "RShoulder", "RElbow", "RWrist")
    assert all(55.0 < m.tracks.rate_hz < 65.0 for m in movements)
    assert all(len(crop_to_reach(m).xy) > 5 for m in movements)


# --- lfd-jax phmm fit / recognize on OpenPose folders and a reach npz (in-process, tiny HMMs) ---

PHMM_FLAGS = ["--n-states", "3", "--min-duration", "2", "--max-duration", "12", "--n-frames", "20",
              "--max-iter", "5", "--markers", "RWrist,RElbow"]


def reach_folder(folder: Path, kind: int, n_frames: int, rng) -> Path:
    """An OpenPose folder of one person whose right wrist moves up (kind 0) or sideways (kind 1)."""
    frames = []
    for t in np.linspace(0.0, 1.0, n_frames):
        p = person((300.0, 200.0))
        pose = np.array(p["pose_keypoints_2d"]).reshape(25, 3)
        move = np.array([0.0, -150.0 * t]) if kind == 0 else np.array([150.0 * t, 0.0])
        for j, name in enumerate(("RWrist", "RElbow")):
            pose[BODY_25.index(name), :2] = np.array([350.0, 250.0]) + move * (1.0 - 0.5 * j) + rng.normal(0, 2, 2)
        p["pose_keypoints_2d"] = pose.ravel().tolist()
        frames.append([p])
    return write_frames(folder, frames)


def test_cli_phmm_on_openpose_folders(tmp_path, capsys):
    from lfd_jax.cli import main

    rng = np.random.default_rng(3)
    for kind, name in enumerate(("up", "side")):
        for rep in range(3):
            reach_folder(tmp_path / "train" / name / f"{name}{rep}", kind, int(rng.integers(24, 32)), rng)
        reach_folder(tmp_path / "test" / f"test_{name}", kind, 28, rng)
    model = tmp_path / "model"
    assert main(["phmm", "fit", str(tmp_path / "train"), "--out", str(model), *PHMM_FLAGS, "--rate-hz", "30"]) == 0
    out = capsys.readouterr().out
    assert "6 inputs, 2 keypoints (pixels) -> D = 4 features" in out and "| up | 3 | 100% |" in out
    manifest = json.loads((model / "model.json").read_text())
    assert manifest["inputs"]["kind"] == "keypoints" and manifest["markers"] == ["RWrist", "RElbow"]
    tests = [str(tmp_path / "test" / f"test_{n}") for n in ("up", "side")]
    assert main(["phmm", "recognize", str(model), *tests, "--label", r"test_(\w+)"]) == 0
    assert "accuracy 2/2 = 100.0%" in capsys.readouterr().out


def test_cli_phmm_on_a_reach_npz(tmp_path, capsys):
    from lfd_jax.cli import main

    rng = np.random.default_rng(4)
    names, sizes, t, xy, offsets = [], [], [], [], [0]
    for p in (1, 2):
        for size in ("S", "L"):
            for rep in range(3):
                n = int(rng.integers(24, 32))
                s = np.linspace(0.0, 1.0, n)[:, None]
                wrist = np.array([3000.0, 2000.0]) + (s * [0.0, -1500.0] if size == "S" else s * [1500.0, 0.0])
                frame = np.stack([np.full((n, 2), 1000.0), wrist + rng.normal(0, 20, (n, 2))], axis=1)
                names.append(f"P{p}_{size}_{rep + 1:02d}")
                sizes.append(size)
                t.append(np.arange(n) / 60.0)
                xy.append(frame)
                offsets.append(offsets[-1] + n)
    path = tmp_path / "reach.npz"
    t_all = np.concatenate(t).astype(np.float32)
    np.savez(path, names=np.array(names), participant=np.array([int(n[1]) for n in names], np.int8),
             size=np.array(sizes), size_cm=np.where(np.array(sizes) == "S", 2.5, 7.5).astype(np.float32),
             offsets=np.array(offsets), t=t_all, xy_dpx=np.concatenate(xy).astype(np.uint16),
             prob=np.full((offsets[-1], 2), 0.9, np.float16), joints=np.array(["Neck", "RWrist"]),
             rtg_onset=np.zeros(len(names), np.float32), rtg_end=np.full(len(names), 10.0, np.float32))
    flags = [f for f in PHMM_FLAGS if f != "RWrist,RElbow" and f != "--markers"]
    model = tmp_path / "model"
    assert main(["phmm", "fit", str(path), "--out", str(model), "--movements", "^P1_", "--reach-phase", *flags]) == 0
    assert "| S | 3 | 100% |" in capsys.readouterr().out
    assert json.loads((model / "model.json").read_text())["markers"] == ["Neck", "RWrist"]
    assert main(["phmm", "recognize", str(model), str(path), "--movements", "^P2_"]) == 0
    out = capsys.readouterr().out
    assert "| P2_L_01 | L | L |" in out and "accuracy 6/6 = 100.0%" in out
    assert main(["phmm", "recognize", str(model), str(path), "--movements", "^P9_"]) == 2
    assert "movements" in capsys.readouterr().err


def test_select_keypoints_rejects_a_name_given_twice(tmp_path):
    tracks = load_openpose_folder(write_frames(tmp_path / "v", [[person((100.0, 100.0))]]), rate_hz=30.0)
    with pytest.raises(ValueError, match="^names: each keypoint may be chosen once, got 'Neck' more than once"):
        select_keypoints(tracks, ["Neck", "RWrist", "Neck"])
    with pytest.raises(ValueError, match=r"^names: no keypoint\(s\) \['Nose2'\] in the tracks"):
        select_keypoints(tracks, ["Nose2"])
    assert select_keypoints(tracks, ["RWrist", "Neck"]).names == ("RWrist", "Neck")
