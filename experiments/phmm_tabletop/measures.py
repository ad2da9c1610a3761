"""Pieces of the PHMM table-top protocol (pure functions): diagnostic features, DTW synthesis error
(eq. 25), phi -> table position, model training, the log-likelihood surface, the human -> robot mapping.
`cfg` arguments are the study's `Config`."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

import crf_jax
import phmm_jax as P
from experiments.data import tabletop as tt
from phmm_jax import retarget
from phmm_jax import multilinear_map
from sim import robot
from sim.scenes import render_frame


def hand_centre(markers):
    """Hand point (..., 3): mean of index knuckle, index tip and thumb tip of markers (..., 7, 3)."""
    return markers[..., 4:7, :].mean(axis=-2)


def diagnostic_features(rec: tt.Recordings) -> np.ndarray:
    """(B, 3) per movement: peak hand height (m), largest hand-sternum distance (m), peak hand speed
    (m/s) — the "simple diagnostic features" the papers say would fail (arm velocity, hand to chest)."""
    hand = hand_centre(rec.markers)  # (B, T, 3)
    valid = np.arange(rec.markers.shape[1])[None, :] < rec.lengths[:, None]
    height = np.where(valid, hand[..., 2], -np.inf).max(1)
    reach = np.where(valid, np.linalg.norm(hand - rec.markers[:, :, 0], axis=-1), -np.inf).max(1)
    speed = np.linalg.norm(np.diff(hand, axis=1), axis=-1) * rec.frame_rate
    speed = np.where(valid[:, 1:], speed, -np.inf).max(1)
    return np.stack([height, reach, speed], axis=1)


def diagnostic_baseline(train: tt.Recordings, test: tt.Recordings) -> float:
    """Test accuracy of a logistic regression on the standardised diagnostic features."""
    f_train, f_test = diagnostic_features(train), diagnostic_features(test)
    mean, std = f_train.mean(0), f_train.std(0)
    model, _ = crf_jax.fit_linear((f_train - mean) / std, train.action, kind="logistic", l2=1e-3)
    return float(np.mean(np.asarray(crf_jax.linear_predict(model, (f_test - mean) / std)) == test.action))


def _dtw_one(a, b):
    """sqrt(mean cost along the DTW path) for sequences a (S, M, 3), b (S', M, 3), cost = mean over
    the M markers of the squared distance (eq. 25 in discrete form)."""
    cost = jnp.mean(jnp.sum((a[:, None] - b[None]) ** 2, -1), -1)  # (S, S')
    big = jnp.inf

    def row(prev, c_row):  # prev: (acc (S',), steps (S',)) of row i-1
        prev_acc, prev_len = prev

        def cell(left, j):
            left_acc, left_len = left
            options = jnp.stack([prev_acc[j], jnp.where(j > 0, prev_acc[j - 1], big), left_acc])
            lens = jnp.stack([prev_len[j], jnp.where(j > 0, prev_len[j - 1], 0.0), left_len])
            k = jnp.argmin(options)
            acc, n = options[k] + c_row[j], lens[k] + 1.0
            return (acc, n), (acc, n)

        _, (acc, n) = jax.lax.scan(cell, (big, 0.0), jnp.arange(c_row.shape[0]))
        return (acc, n), None

    first_acc = jnp.cumsum(cost[0])
    first_len = jnp.arange(1.0, cost.shape[1] + 1.0)
    (acc, n), _ = jax.lax.scan(row, (first_acc, first_len), cost[1:])
    return jnp.sqrt(acc[-1] / n[-1])


@jax.jit
def dtw_rms(a, b):
    """Eq. 25 for a batch: a, b (B, S, M, 3) -> (B,) RMS marker distance along the DTW path."""
    return jax.vmap(_dtw_one)(a, b)


def synthesis_error(synth, reference, trim: float = 0.1) -> np.ndarray:
    """Eq. 25 (B,) in metres between synthesised and reference movements (B, S, 3 M) after cutting
    the first and last `trim` of each."""
    s = synth.shape[1]
    lo, hi = int(round(trim * s)), s - int(round(trim * s))
    shape = synth.shape[:1] + (hi - lo, -1, 3)
    return np.asarray(dtw_rms(jnp.asarray(synth[:, lo:hi].reshape(shape)),
                              jnp.asarray(reference[:, lo:hi].reshape(shape))))


def phi_to_position(corner_targets, phi) -> np.ndarray:
    """Table position (M, 3) of interpolation parameters phi (M, 2) (eqs. 4-6)."""
    return np.asarray(jax.vmap(lambda p: multilinear_map(jnp.asarray(corner_targets), p))(jnp.asarray(phi)))


def final_markers(X, names=("index_tip",)) -> np.ndarray:
    """(B, 3 M) the markers `names` of resampled movements X (B, S, 21) at the hold: the sample where
    the hand centre is farthest from where it started (the end point before the withdrawal)."""
    markers = np.asarray(X).reshape(*X.shape[:2], len(tt.MARKERS), 3)
    hand = hand_centre(markers)
    hold = np.argmax(np.linalg.norm(hand - hand[:, :1], axis=-1), axis=1)  # (B,)
    at = markers[np.arange(len(markers)), hold]  # (B, 7, 3)
    return at[:, [tt.MARKERS.index(n) for n in names]].reshape(len(at), -1)


def regression_baseline(X_train, target_train, action_train, X_test, action_test,
                        names=("index_tip",)) -> np.ndarray:
    """The baseline every PHMM position figure is reported beside: per action, an ordinary
    least-squares affine map from the final finger position (`final_markers`; other markers with
    `names`) to the table position (x, y), fitted on the training movements. Returns (B_test, 3)
    predicted positions (z: the training targets' table height)."""
    f_train, f_test = final_markers(X_train, names), final_markers(X_test, names)
    target_train = np.asarray(target_train, float)
    pred = np.tile(target_train[:1], (len(f_test), 1))
    affine = lambda f: np.concatenate([f, np.ones((len(f), 1))], axis=1)  # noqa: E731
    for a in np.unique(action_test):
        coef, *_ = np.linalg.lstsq(affine(f_train[action_train == a]), target_train[action_train == a, :2], rcond=None)
        pred[action_test == a, :2] = affine(f_test[action_test == a]) @ coef
    return pred


def inner_mask(rows: int, cols: int) -> np.ndarray:
    """(rows * cols,) True off the border of the raster."""
    mask = np.zeros((rows, cols), bool)
    mask[1:-1, 1:-1] = True
    return mask.ravel()


def train_models(cfg, X_train, train: tt.Recordings, reps: int):
    """PHMMs 3x3 and 2x2 and classical HMMs for both actions. X_train (B, S, D) target-major per action."""
    hmm_cfg = P.HMMConfig(n_states=cfg.n_states, min_duration=cfg.min_duration, max_duration=cfg.max_duration)
    classic_cfg = P.HMMConfig(n_states=cfg.n_states, min_duration=1, max_duration=None)
    options = P.FitOptions(max_iter=cfg.n_iter)
    models = {"3x3": [], "2x2": [], "hmm": []}
    for a in range(len(tt.ACTIONS)):
        groups = X_train[train.action == a].reshape(9, reps, *X_train.shape[1:])
        models["3x3"].append(P.fit_phmm(list(groups), (3, 3), hmm_cfg, options=options))
        models["2x2"].append(P.fit_phmm([groups[k] for k in (0, 2, 6, 8)], (2, 2), hmm_cfg, options=options))
        models["hmm"].append(P.fit_hmm(X_train[train.action == a], config=classic_cfg, options=options))
    return models


def average_movements(cfg, X_test, test: tt.Recordings, n_positions: int) -> np.ndarray:
    """The reference movement of every (action, test position): (A, K, S, D). An HMM of
    `average_states` states (1 to 2 S / states steps each) per position, trained on its repetitions and
    re-synthesised. The per-position HMMs are trained together as a 1-D PHMM over the K positions
    (a shared global model, then per-position EM with the means re-estimated once on the position's
    own repetitions: PHMM §III-B1), and each is re-synthesised at its own grid point."""
    longest = max(2, -(-2 * X_test.shape[1] // cfg.average_states))  # room for every sequence length
    avg_cfg = P.HMMConfig(n_states=cfg.average_states, min_duration=1, max_duration=longest)
    out = []
    for a in range(len(tt.ACTIONS)):
        groups = X_test[test.action == a].reshape(n_positions, -1, *X_test.shape[1:])
        model = P.fit_phmm(list(groups), (n_positions,), avg_cfg, options=P.FitOptions(max_iter=cfg.n_iter))
        out.append(np.asarray(P.synthesize(model, P.grid_points((n_positions,)), length=X_test.shape[1])))
    return np.stack(out)


def loglik_surface(phmm: P.PHMM, x, points: int = 41, margin: float = 0.1):
    """log p(x | lambda^(u, v)) on a points x points grid over [-margin, 1 + margin]^2: (axis, L (points, points))."""
    axis = np.linspace(-margin, 1 + margin, points)
    phi = np.stack(np.meshgrid(axis, axis, indexing="ij"), -1).reshape(-1, 2)
    X = np.broadcast_to(x, (phi.shape[0],) + x.shape)
    return axis, np.asarray(P.phmm_log_likelihood(phmm, X, phi)).reshape(points, points)


def local_maxima(surface) -> np.ndarray:
    """Values of the strict 8-neighbour local maxima of a 2-D array (edges padded with -inf), best first."""
    pad = np.pad(surface, 1, constant_values=-np.inf)
    centre = pad[1:-1, 1:-1]
    neighbours = [pad[1 + di:pad.shape[0] - 1 + di, 1 + dj:pad.shape[1] - 1 + dj]
                  for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]
    return np.sort(centre[np.all([centre > n for n in neighbours], axis=0)])[::-1]


class RobotSetup:
    """The human -> robot mapping of one study: reference shoulder (mean over the training
    movements), scale (robot arm / mean human arm), table height and targets in the robot's world."""

    def __init__(self, train: tt.Recordings, targets):
        valid = np.arange(train.markers.shape[1])[None, :] < train.lengths[:, None]
        frames = train.markers[valid]  # (F, 7, 3)
        self.shoulder = frames[:, 1].mean(0)
        arm = (np.linalg.norm(frames[:, 2] - frames[:, 1], axis=-1)
               + np.linalg.norm(hand_centre(frames) - frames[:, 2], axis=-1))
        self.scale = (robot.UPPER_ARM_M + robot.FOREARM_M) / float(np.median(arm))
        reaching = train.action == tt.ACTIONS.index("reaching")
        hand = hand_centre(train.markers[reaching])
        closest = np.argmin(np.linalg.norm(hand - train.target[reaching][:, None], axis=-1)
                            + np.where(valid[reaching], 0.0, np.inf), axis=1)
        self.grasp_height = float(np.mean(hand[np.arange(len(closest)), closest, 2] - tt.TABLE_HEIGHT_M))
        self.targets = self.to_robot(np.asarray(targets) + np.array([0.0, 0.0, self.grasp_height]))
        self.table_z = float(self.to_robot(np.array([0.0, 0.0, tt.TABLE_HEIGHT_M]))[2])
        # The robot's table starts 5 cm nearer than the person's (a stricter collision check).
        self.table_near_y = float(self.to_robot(np.array([0.0, tt.TABLE_EDGE_Y - 0.05, 0.0]))[1])
        table_targets = self.to_robot(np.asarray(targets))
        self.model = mujoco.MjModel.from_xml_string(
            robot.arm_scene_xml(self.table_z, self.table_near_y, targets=table_targets))

    def to_robot(self, points):
        return robot.SHOULDER_POS + self.scale * (np.asarray(points) - self.shoulder)

    def play(self, movements):
        """Retarget movements (K, S, 21) and play them back: (angles, qpos (K, S, 5), [Playback] * K)."""
        angles = retarget(movements, robot.UPPER_ARM_M, robot.FOREARM_M, shoulder=self.shoulder,
                          scale=self.scale)
        qpos = np.concatenate([np.asarray(angles.shoulder), np.asarray(angles.elbow)[..., None],
                               np.asarray(angles.wrist)[..., None]], axis=-1)
        return angles, qpos, [robot.play(self.model, q) for q in qpos]


def robot_metrics(setup: RobotSetup, angles, playbacks) -> dict:
    """Reach error (robot scale, cm), elbow-plane distance (mm), table clearance (cm)."""
    grasp = np.stack([p.grasp for p in playbacks])  # (K, S, 3)
    reach = np.linalg.norm(grasp - setup.targets[:, None], axis=-1).min(1) * 100
    elbow = np.stack([p.elbow for p in playbacks]) - robot.SHOULDER_POS
    normal = np.cross(np.asarray(angles.elbow_point), np.asarray(angles.hand))
    plane = np.abs(np.sum(elbow * normal, -1)) / np.linalg.norm(normal, axis=-1) * 1000
    clearance = np.stack([p.table_distance for p in playbacks]) * 100
    return {
        "robot_reach_error_cm_mean": float(reach.mean()),
        "robot_reach_error_cm_max": float(reach.max()),
        "robot_reach_error_human_scale_cm_mean": float(reach.mean() / setup.scale),
        "robot_scale": setup.scale,
        "robot_elbow_plane_distance_mm_max": float(plane.max()),
        "robot_table_clearance_cm_min": float(clearance.min()),
        "robot_frames_penetrating_table": int(np.sum(clearance < 0.0)),
        "robot_frames": int(clearance.size),
    }, reach


def render_reach(setup: RobotSetup, qpos, width: int = 480, height: int = 360):
    """Side and front renderings (height, 2 width, 3) of the robot at joint angles qpos (5,)."""
    return np.concatenate([render_frame(setup.model, qpos, width, height, camera=c)
                           for c in ("side", "front")], axis=1)
