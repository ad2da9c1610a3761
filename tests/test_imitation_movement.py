"""The imitation loop's movement finder (`lfd_jax.imitation.movement`) on synthetic streams of two
tiny PHMM classes with known class, target and frames: a movement still under way when the recording
stops (the hand drops out of the table's view, the tracker follows it down and then loses it) is
ended at the last measured frame and recognised, as the video study's pointing demonstrations need."""
import numpy as np
import pytest

import phmm_jax as P
from lfd_jax import imitation as im
from tests.synthetic_movements import out_and_back

CFG = P.HMMConfig(n_states=4, min_duration=2, max_duration=8)  # paths of 8..32 frames
REST = np.array([-0.25, 0.0, -0.40])  # hand - face at rest (m)
START = 8  # the rest frames before the movement


def target(phi) -> np.ndarray:
    """hand - face at the target of parameter φ (2,) in [0, 1]^2."""
    return REST + np.array([0.05 + 0.10 * phi[0], -0.20 - 0.15 * phi[1], 0.12])


def movement(rng, kind: int, phi, noise: float = 0.003) -> np.ndarray:
    """(L, 3) from REST to `target(phi)`, a hold and back: kind 0 straight ("point"), kind 1 over an arc
    lifted in z and drawn back in x ("transfer")."""
    return out_and_back(rng, kind, REST, target(phi), noise)


@pytest.fixture(scope="module")
def online():
    rng = np.random.default_rng(0)
    corners = P.grid_points((2, 2))
    phmms = [P.fit_phmm([[movement(rng, kind, phi) for _ in range(3)] for phi in corners], (2, 2), CFG,
                        options=P.FitOptions(max_iter=4)) for kind in (0, 1)]
    return im.recognizer(phmms, sigma_m=0.02, threshold_m=0.08, window=3)


def test_a_movement_under_way_when_the_recording_stops_ends_at_the_last_measured_frame(online):
    rng = np.random.default_rng(3)
    phi = np.array([1.0, 0.0])
    move = movement(rng, 0, phi)
    drop = move[-1] + np.outer(np.arange(1, 4), [0.0, 0.0, -0.05])  # followed below the table top, 5 cm a frame
    stream = np.concatenate([np.repeat(REST[None], START, 0), move, drop])
    last = len(stream) - 1
    stream = np.concatenate([stream, stream[-1:]])  # then lost (held) as the recording stops
    measured = np.arange(len(stream)) <= last
    kind, xy, start, end = im.movement(online, stream, merge_gap=10, measured=measured)
    assert kind == "point" and end == last and abs(start - START) <= 2
    np.testing.assert_allclose(xy, im.phi_to_xy(phi), atol=0.06)  # within 6 cm (the area: 57 x 26 cm)


def test_a_movement_that_settles_is_the_detectors_own(online):
    rng = np.random.default_rng(4)
    move = movement(rng, 1, np.array([0.0, 1.0]))
    stream = np.concatenate([np.repeat(REST[None], START, 0), move, np.repeat(move[-1:], 8, 0)])
    found = im.movement(online, stream, merge_gap=10)
    assert found[0] == "transfer" and START - 2 <= found[2] < found[3] <= START + len(move)
    # nothing runs at the end: where the tracking stopped does not matter
    assert found[2:] == im.movement(online, stream, 10, measured=np.arange(len(stream)) < START + len(move))[2:]
    with pytest.raises(ValueError, match="measured"):
        im.movement(online, stream, 10, measured=np.ones(len(stream) - 1, bool))


def test_a_pointing_s_object_is_the_likeliest_of_the_known_ones(online):
    rng = np.random.default_rng(5)
    phis = np.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]])  # the objects' parameters; the movement is to the first
    objects_xy = im.phi_to_xy(phis)
    segment = movement(rng, 0, phis[0])
    point = online.phmms[im.KINDS.index("point")]
    assert im.likeliest_object(point, segment, objects_xy, online.options.max_frames) == 0
    # the padding changes nothing: the likelihood of the unpadded movement at each object decides
    for i, phi in enumerate(phis):
        segment = movement(rng, 0, phi)
        loglik = [float(P.phmm_log_likelihood(point, segment, p)[0]) for p in phis]
        assert im.likeliest_object(point, segment, objects_xy, online.options.max_frames) == int(np.argmax(loglik)) == i



def test_a_hand_lost_between_two_detected_parts_does_not_split_the_movement(online, monkeypatch):
    # the detector ends an event where the lost hand's held position stands still (a carried object hides
    # it) and finds the rest later: lost frames are no rest, measured still frames are
    rng = np.random.default_rng(6)
    move = movement(rng, 1, np.array([0.5, 0.5]))
    stream = np.concatenate([np.repeat(REST[None], START, 0), move, np.repeat(REST[None], 30, 0)])
    parts = ((START, START + 8), (START + 19, START + 28))  # 10 frames between them
    events = P.OnlineEvents(np.ones(2, bool), *(np.array(v, np.int32) for v in zip(*parts)),
                            np.array([p[1] + 3 for p in parts], np.int32), np.ones(2, np.int32), np.zeros((2, 2)),
                            np.zeros((2, 2)))
    monkeypatch.setattr(P, "run_online", lambda rec, x: events)
    measured = np.ones(len(stream), bool)
    assert im.movement(online, stream, merge_gap=6, measured=measured)[2:] == parts[1]  # the longer part
    measured[parts[0][1] + 1:parts[1][0]] = False
    assert im.movement(online, stream, merge_gap=6, measured=measured)[2:] == (parts[0][0], parts[1][1])
