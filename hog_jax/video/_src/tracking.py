"""α-β tracking of blob ellipses: hands, face and manipulated objects (LEVELSET TR §3.7; LfD 2009
§III-A: hand and face masks from the skin mask "using connected components detection or with an
αβ-filter when hand and face blobs merge").

Each of M targets is an ellipse (centroid, second moments; `blobs` conventions) with a
velocity. Per frame (`lax.scan` over a video, `vmap` over videos), given the frame's connected
components (`connected_blobs`: a label image and padded blob arrays, made before with OpenCV):

1. predict x^- = x + v dt (a constant-velocity α-β filter);
2. associate by predicted position: target m takes the blob with the pixel nearest to x^-_m in the
   Mahalanobis distance of its own ellipse (cov + `cov_floor` I), if that pixel lies inside the
   ellipse scaled by `gate` (the ellipse has semi-axes 2 sqrt(eig): d^2 <= (2 gate)^2). Targets choose
   independently, so two may take one blob: it is *merged*;
3. measure: a blob of its own gives its moments. A merged blob is split by the ellipses, after
   Argyros & Lourakis, "Real-time tracking of multiple skin-colored objects with a possibly moving
   camera", ECCV 2004 (the report's tracker [13]): a pixel that no other sharer's ellipse (grown by
   2 px) explains is the target's own if inside its grown ellipse, or, outside every ellipse, if the
   target is nearest along the ray to its centre (their distance D). A target's position in a merged
   blob is where its own pixels as predicted by its ellipse match those seen: a few fixed-point steps
   x <- x + (centroid seen - centroid predicted), so a hand overlapping the face is located by the
   part of it that shows (the centroid of its window would be pulled into the face). Its ellipse is
   held while merged. The prediction separates hand and face (LEVELSET TR §3.7);
4. correct with the residual r = z - x^-: x = x^- + α r, v = v + β r / dt. Without a blob a target
   coasts on x^- (observed False) and after `n_lost` frames it is lost (velocity 0, position frozen).
   In a merged blob with less than `min_evidence` of its ellipse's area in own pixels (a hand in front
   of the face, or gone beside it) it is *concealed*: it coasts with its velocity damped by
   `merge_damping` per frame (it most likely stops there), and after `n_hidden` frames it is lost;
5. acquire: once a frame has had `min_init` blobs, every target not tracked (never acquired, lost with
   `reacquire`, concealed, or coasting) takes, in target order, a blob no observed target took: a never-acquired
   target by its `init` rule ("top" highest centroid, "bottom", "left", "right", "largest";
   "left_of_first" / "right_of_first": the leftmost / rightmost of the blobs beyond that side of
   target 0's ellipse (its centre -/+ 2 sigma along x), none while target 0 is not tracked), the others
   the nearest to their last position (a concealed one only within twice its gate, a coasting one within its
   gate times 1 + the frames since its last measurement: a constant-velocity prediction's error grows with
   them, and a track acquired on the first pixels of a rising hand, with no velocity and a small ellipse,
   would otherwise coast until lost while the hand moves on beside it; a lost one with a side rule only
   among the blobs on its side: a right hand lost behind an object would otherwise take a piece of the
   other arm, the free blob nearest its stale position). Skin: init ("top", "left_of_first",
   "right_of_first") makes target 0 the face (the highest skin blob), target 1 the blob furthest left in the image and
   left of the face (the right hand of a person facing the camera) and target 2 the furthest right of
   the face (the other hand). The side matters where the right hand is out of view when tracking
   starts (below the table) and the other arm shows as two blobs (hand and bare forearm): "left" would
   take the forearm, and the right hand, once it appears, would find every target taken. The face's
   extent matters where the neck shows as a skin blob of its own just below the face.

Gains: `alpha_beta_gains(tracking_index)` gives Kalata's steady-state optimal α, β for the tracking
index Λ = σ_a dt^2 / σ_z (acceleration and measurement noise; P. R. Kalata, "The tracking index: a
generalized parameter for α-β and α-β-γ target trackers", IEEE Trans. AES 20(2), 1984):
α = (-Λ² - 8Λ + (Λ + 4) sqrt(Λ² + 8Λ)) / 8,  β = (Λ² + 4Λ - Λ sqrt(Λ² + 8Λ)) / 4, evaluated in a form
without cancellation (see `alpha_beta_gains`). The defaults
α = 0.75, β = 0.5 are Λ = 1 (a hand: σ_a ~ 400 px/s² at 25 fps against ~1 px of centroid noise).

Shapes: B videos, T frames, M targets, K blob slots, H x W pixels.
"""
from __future__ import annotations

import dataclasses
import math
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from hog_jax.video._src.blobs import Blobs, ellipse_from_sums
from lfd_common import as_array, check_choice, check_int, check_real

__all__ = ["INIT_RULES", "TrackOptions", "TrackState", "Tracks", "alpha_beta_gains", "initial_track_state", "track",
           "track_chunk"]

INIT_RULES = ("top", "bottom", "left", "right", "largest", "left_of_first", "right_of_first")
_SIDE_RULES = INIT_RULES[5:]  # relative to target 0: not target 0's own rule
_REFINE_STEPS = 3  # fixed-point steps of a merged target's position per frame
_RIM_PX = 2.0  # a sharer's ellipse, grown by this many pixels, explains its blob's rim (an ellipse is only a model)


class TrackState(NamedTuple):
    """The scan carry of the α-β tracker for one video (LEVELSET TR §3.7).

    Attributes:
        position: (M, 2) px.
        velocity: (M, 2) px per dt.
        cov: (M, 2, 2) ellipse second moments.
        missed: (M,) int32 frames without a blob.
        hidden: (M,) int32 frames concealed in a merged blob.
        acquired: (M,) bool.
        started: () bool, a frame had >= min_init blobs.
    """

    position: Float[Array, "M 2"]
    velocity: Float[Array, "M 2"]
    cov: Float[Array, "M 2 2"]
    missed: Int[Array, " M"]
    hidden: Int[Array, " M"]
    acquired: Bool[Array, " M"]
    started: Bool[Array, ""]


class Tracks(NamedTuple):
    """The tracked targets per frame (LEVELSET TR §3.7; LfD 2009 §III-A).

    Leading axes (T,) or (B, T).

    Attributes:
        position: (.., M, 2) the corrected position, px.
        velocity: (.., M, 2) px per dt.
        cov: (.., M, 2, 2) the ellipse.
        area: (.., M) the pixels measured (0 when not observed).
        blob: (.., M) int32 the blob slot taken (-1 none).
        observed: (.., M) bool, measured this frame (not a prediction).
        merged: (.., M) bool, its gated blob was shared with another target (measured by a split of
            it, or coasting).
        lost: (.., M) bool, not tracked: never acquired, or n_lost frames unseen (position then holds
            the last estimate, or 0 before acquisition).
    """

    position: Float[Array, "*T M 2"]
    velocity: Float[Array, "*T M 2"]
    cov: Float[Array, "*T M 2 2"]
    area: Float[Array, "*T M"]
    blob: Int[Array, "*T M"]
    observed: Bool[Array, "*T M"]
    merged: Bool[Array, "*T M"]
    lost: Bool[Array, "*T M"]


@dataclasses.dataclass(frozen=True)
class TrackOptions:
    """The α-β tracker's options (`track`; LEVELSET TR §3.7), validated on construction.

    The default gains α = 0.75, β = 0.5 are Kalata's steady-state optimum for the tracking index
    Λ = 1 (`alpha_beta_gains`; a hand: σ_a ~ 400 px/s² at 25 fps against ~1 px of centroid noise).

    Attributes:
        alpha: the position gain, 0 < alpha <= 1.
        beta: the velocity gain, 0 < beta < 4 - 2 alpha (the stability region).
        dt: the frame period, > 0 (velocity is in px per dt).
        gate: the association gate in units of the target's own ellipse, > 0: a blob is taken when
            its nearest pixel lies inside the ellipse (semi-axes 2 sqrt(eig)) scaled by `gate`.
        n_lost: frames without a blob before a target is lost, >= 1.
        n_hidden: frames concealed in a merged blob before a target is lost, >= 1.
        min_init: the blobs a frame needs before the first acquisition, >= 1 and at most the blob
            slots K (None: M, all targets at once).
        reacquire: lost targets may take a free blob again.
        cov_floor: px^2 added to every ellipse for the distances, > 0 (a 1-pixel blob has cov 0).
        min_evidence: the fraction of its ellipse's area a target needs in own pixels of a merged
            blob to count as observed, >= 0.
        merge_damping: the factor on a concealed target's velocity per frame, in [0, 1] (1: pure
            coasting).

    Raises:
        ValueError: naming the field for a value out of its range.
    """

    alpha: float = 0.75
    beta: float = 0.5
    dt: float = 1.0
    gate: float = 2.0
    n_lost: int = 5
    n_hidden: int = 50
    min_init: int | None = None
    reacquire: bool = True
    cov_floor: float = 1.0
    min_evidence: float = 0.1
    merge_damping: float = 0.5

    def __post_init__(self):
        alpha = check_real(self.alpha, "alpha", min_value=0.0, max_value=1.0, exclusive_min=True)
        beta = check_real(self.beta, "beta", min_value=0.0, exclusive_min=True)
        if beta >= 4.0 - 2.0 * alpha:
            raise ValueError(f"beta: must be < 4 - 2 alpha = {4.0 - 2.0 * alpha:g} for a stable filter, got {beta}")
        check_real(self.dt, "dt", min_value=0.0, exclusive_min=True)
        check_real(self.gate, "gate", min_value=0.0, exclusive_min=True)
        check_int(self.n_lost, "n_lost", min_value=1)
        check_int(self.n_hidden, "n_hidden", min_value=1)
        if self.min_init is not None:
            check_int(self.min_init, "min_init", min_value=1)
        check_choice(self.reacquire, "reacquire", (True, False))
        check_real(self.cov_floor, "cov_floor", min_value=0.0, exclusive_min=True)
        check_real(self.min_evidence, "min_evidence", min_value=0.0)
        check_real(self.merge_damping, "merge_damping", min_value=0.0, max_value=1.0)


class _Options(NamedTuple):
    alpha: Float[Array, ""]
    beta: Float[Array, ""]
    dt: Float[Array, ""]
    gate2: Float[Array, ""]
    cov_floor: Float[Array, ""]
    n_lost: Int[Array, ""]
    n_hidden: Int[Array, ""]
    min_init: Int[Array, ""]
    reacquire: Bool[Array, ""]
    min_evidence: Float[Array, ""]
    merge_damping: Float[Array, ""]
    rules: Int[Array, " M"]


_MAX_TRACKING_INDEX = 1e8  # beyond about 2.7e8, α = 1 - 4/Λ² + ... rounds to 1 in float64


def alpha_beta_gains(tracking_index: float) -> tuple[float, float]:
    """Kalata's steady-state optimal α-β gains for a tracking index (Kalata 1984, IEEE Trans. AES 20(2)).

    For Λ = σ_a dt^2 / σ_z (acceleration against measurement noise), Kalata's closed form is
    α = (-Λ² - 8Λ + (Λ + 4) sqrt(Λ² + 8Λ)) / 8, β = (Λ² + 4Λ - Λ sqrt(Λ² + 8Λ)) / 4. It subtracts
    nearly equal numbers for large Λ (α = 1.002 at Λ = 1e7, (0, 0) at 1e9); computed here by the
    equivalent form without cancellation: with r = sqrt(Λ² + 8Λ) and s = sqrt(1 - α) = 4 / (Λ + 4 + r)
    (the root in (0, 1) of Λ s = 2 (1 - s)², i.e. Kalata's β² / (1 - α) = Λ² with β = 2 (1 - s)²),
    α = (1 - s)(1 + s) = (Λ + r)(Λ + 8 + r) / (Λ + 4 + r)² and β = Λ s = 4 Λ / (Λ + 4 + r). Λ = 1 gives the
    `TrackOptions` defaults α = 0.75, β = 0.5. The gains lie in the stability region (0 < α < 1,
    0 < β < 2 (2 - α)) and grow with Λ.

    Args:
        tracking_index: Λ, 0 < Λ <= 1e8 (beyond it α rounds to 1 in float64, the edge of the stability
            region).

    Returns:
        (alpha, beta).

    Raises:
        ValueError: `tracking_index` <= 0, above 1e8 or not finite.
    """
    lam = check_real(tracking_index, "tracking_index", min_value=0.0, exclusive_min=True,
                     max_value=_MAX_TRACKING_INDEX)
    u = lam + math.sqrt(lam) * math.sqrt(lam + 8.0)  # Λ + r, r = sqrt(Λ² + 8Λ) without forming Λ²
    d = u + 4.0
    return u * (u + 8.0) / (d * d), 4.0 * lam / d


def _min_eig(s):
    """The smaller eigenvalue of symmetric (..., 2, 2) matrices."""
    a, b, c = s[..., 0, 0], s[..., 0, 1], s[..., 1, 1]
    return (a + c) / 2 - jnp.sqrt(((a - c) / 2) ** 2 + b * b)


def _inv2(s):
    """Inverse of symmetric positive-definite (..., 2, 2) matrices in closed form."""
    a, b, c = s[..., 0, 0], s[..., 0, 1], s[..., 1, 1]
    det = a * c - b * b
    return jnp.stack([jnp.stack([c, -b], -1), jnp.stack([-b, a], -1)], -2) / det[..., None, None]


def _distances(centres, inv, H: int, W: int):
    """Pixel offsets dx (M, 1, W), dy (M, H, 1) from each centre and squared Mahalanobis distances (M, H, W)."""
    dx = jnp.arange(W, dtype=centres.dtype)[None, None, :] - centres[:, 0, None, None]
    dy = jnp.arange(H, dtype=centres.dtype)[None, :, None] - centres[:, 1, None, None]
    m2 = (inv[:, 0, 0, None, None] * dx * dx + 2 * inv[:, 0, 1, None, None] * dx * dy
          + inv[:, 1, 1, None, None] * dy * dy)
    return dx, dy, m2


def _split(centres, inv, rim2, same, in_blob):
    """The split of merged blobs with the ellipses at `centres` (M, 2) (module step 3): own (M, H, W) the
    pixels no other sharer explains that are the target's (inside its ellipse grown by the rim, or
    nearest to it), hidden (M, H, W) those inside its ellipse that another sharer covers, and the sums
    (count, dx, dy) about `centres` of own and of the own pixels predicted there (3, M) each."""
    M = centres.shape[0]
    dx, dy, m2 = _distances(centres, inv, *in_blob.shape[-2:])
    grown = m2 <= rim2[:, None, None]
    explained = jnp.any((same & ~jnp.eye(M, dtype=bool))[:, :, None, None] & grown[None], axis=1)
    unexplained = ~jnp.any(same[:, :, None, None] & grown[None], axis=1)
    gap = jnp.sqrt(dx * dx + dy * dy) * (1.0 - 2.0 / jnp.sqrt(jnp.maximum(m2, 4.0)))  # outside the ellipse, on
    closest = gap <= jnp.min(jnp.where(same[:, :, None, None], gap[None], jnp.inf), axis=1)  # the ray to its centre
    own = in_blob & ~explained & (~unexplained | closest)
    inside = m2 <= 4.0
    seen, model = own.astype(dx.dtype), (inside & ~explained).astype(dx.dtype)
    sums = jnp.sum(jnp.stack([seen, dx * seen, dy * seen, model, dx * model, dy * model]), axis=(-2, -1))
    return own, in_blob & explained & inside, sums[:3], sums[3:]


def _shift(sums_seen, sums_model):
    """Centroid of the seen pixels minus that of the predicted ones (M, 2), and where both exist (M,)."""
    ok = (sums_seen[0] > 0) & (sums_model[0] > 0)
    seen = sums_seen[1:] / jnp.where(ok, sums_seen[0], 1.0)
    model = sums_model[1:] / jnp.where(ok, sums_model[0], 1.0)
    return jnp.where(ok[:, None], (seen - model).T, 0.0), ok


def _step(opts: _Options, state: TrackState, frame):
    labels, blob_area, blob_centroid, blob_cov, valid = frame
    M, K = state.position.shape[0], blob_area.shape[0]
    H, W = labels.shape
    tracked = state.acquired & (state.missed < opts.n_lost) & (state.hidden < opts.n_hidden)
    pred = state.position + state.velocity * opts.dt
    floored = state.cov + opts.cov_floor * jnp.eye(2)
    inv = _inv2(floored)
    dx, dy, m2 = _distances(pred, inv, H, W)

    # association: the blob with the nearest pixel, gated
    member = labels[None] == jnp.arange(1, K + 1)[:, None, None]  # (K, H, W)
    nearest = jnp.min(jnp.where(member[None], m2[:, None], jnp.inf), axis=(-2, -1))  # (M, K)
    nearest = jnp.where(valid[None], nearest, jnp.inf)
    j = jnp.argmin(nearest, axis=1)
    ok = tracked & (jnp.min(nearest, axis=1) <= opts.gate2)
    same = ok[:, None] & ok[None, :] & (j[:, None] == j[None, :])  # (M, M), the diagonal where ok
    shared = ok & (jnp.sum(same, axis=1) > 1)

    # measurement: a blob of its own -> its moments; a merged blob -> the position at which the target's
    # visible part (what no other sharer explains) matches the visible part seen, by fixed-point steps
    in_blob = ok[:, None, None] & (labels[None] == (j + 1)[:, None, None])
    rim2 = 4.0 * (1.0 + _RIM_PX / (2.0 * jnp.sqrt(_min_eig(floored)))) ** 2

    def refine(_, carry):
        centres = carry[0]
        own, hidden, sums_seen, sums_model = _split(centres, inv, rim2, same, in_blob)
        shift, both = _shift(sums_seen, sums_model)
        return jnp.where((shared & both)[:, None], centres + shift, centres), own, hidden, sums_seen[0]

    empty = jnp.zeros_like(in_blob)  # the split's masks and evidence come from the last step's start
    centres, own, hidden, n_seen = jax.lax.fori_loop(0, _REFINE_STEPS, refine, (pred, empty, empty, jnp.zeros(M)))
    w = jnp.where(shared[:, None, None], own | hidden, in_blob).astype(pred.dtype)  # its area: seen + hidden
    dxw, dyw = dx * w, dy * w  # moments about the prediction, in one reduction (d is small: no cancellation)
    meas = ellipse_from_sums(pred, *jnp.sum(jnp.stack([w, dxw, dyw, dx * dxw, dx * dyw, dy * dyw]), axis=(-2, -1)))
    ellipse_area = 4.0 * jnp.pi * jnp.sqrt(floored[:, 0, 0] * floored[:, 1, 1] - floored[:, 0, 1] ** 2)
    evidence = n_seen >= opts.min_evidence * ellipse_area
    observed = ok & meas.found & (~shared | evidence)
    residual = jnp.where(shared[:, None], centres - pred, meas.centroid - pred)

    # α-β correction, or coasting
    position = jnp.where(tracked[:, None], jnp.where(observed[:, None], pred + opts.alpha * residual, pred),
                         state.position)
    velocity = jnp.where(observed[:, None], state.velocity + opts.beta * residual / opts.dt, state.velocity)
    cov = jnp.where((observed & ~shared)[:, None, None], meas.cov, state.cov)
    concealed = shared & ~observed  # inside another target's blob: most likely it stops there (a hand at the face)
    missed = jnp.where(tracked, jnp.where(observed | concealed, 0, state.missed + 1), state.missed)
    hidden = jnp.where(concealed, state.hidden + 1, jnp.where(tracked, 0, state.hidden))
    velocity = jnp.where(concealed[:, None], opts.merge_damping * velocity, velocity)
    gone = tracked & ((missed >= opts.n_lost) | (hidden >= opts.n_hidden))
    velocity = jnp.where(gone[:, None], 0.0, velocity)  # lost: stop, don't drift

    # acquisition of untracked targets from blobs no tracked target took
    coasting = tracked & ~gone & ~observed & ~concealed
    started = state.started | (jnp.sum(valid) >= opts.min_init)
    free = valid & ~jnp.any(observed[:, None] & (j[:, None] == jnp.arange(K)[None]), axis=0)
    x = blob_centroid[:, 0]
    fresh, k = [], []
    for m in range(M):  # in priority order; only scalars per target, so the unrolled loop stays small
        dist = jnp.sum((blob_centroid - state.position[m]) ** 2, axis=-1)
        if m:  # target 0's ellipse after this frame's acquisition: the side rules' reference
            one = jnp.arange(K) == k[0]
            first_x = jnp.where(fresh[0], jnp.sum(jnp.where(one, x, 0.0)), position[0, 0])
            first_var = jnp.where(fresh[0], jnp.sum(jnp.where(one, blob_cov[:, 0, 0], 0.0)), cov[0, 0, 0])
            half_width = 2.0 * jnp.sqrt(jnp.maximum(first_var, 0.0))
            first_there = tracked[0] | fresh[0]
        else:
            first_x, half_width, first_there = jnp.float32(0.0), jnp.float32(0.0), jnp.asarray(False)
        by_rule = jnp.stack([blob_centroid[:, 1], -blob_centroid[:, 1], x, -x, -blob_area,
                             jnp.where(first_there & (x < first_x - half_width), x, jnp.inf),
                             jnp.where(first_there & (x > first_x + half_width), -x, jnp.inf)])  # INIT_RULES order
        rule = jnp.sum(jnp.where((jnp.arange(len(INIT_RULES)) == opts.rules[m])[:, None], by_rule, 0.0), axis=0)
        # a concealed target takes a free blob only near it (twice its gate): the hand leaving the face; a
        # coasting one within its gate times 1 + the frames since its last measurement (its prediction's error
        # grows with them; a fresh track's velocity is unknown, and a fast hand leaves a small blob's gate)
        allowed = free & (~concealed[m] | (nearest[m] <= 4.0 * opts.gate2))
        allowed = allowed & (~coasting[m] | (nearest[m] <= opts.gate2 * (1.0 + missed[m]) ** 2))
        # an untracked target (never acquired, or lost: its last position is stale) takes only a blob its rule
        # admits: a lost right hand returns beyond the face's left, not as a piece of the other arm
        allowed = allowed & ((state.acquired[m] & tracked[m]) | jnp.isfinite(rule))
        score = jnp.where(allowed, jnp.where(state.acquired[m], dist, rule), jnp.inf)
        k.append(jnp.argmin(score))
        seeking = (~tracked[m] & (~state.acquired[m] | opts.reacquire)) | concealed[m] | coasting[m]
        fresh.append(seeking & started & jnp.any(allowed))
        free = free & ~(fresh[m] & (jnp.arange(K) == k[m]))
    fresh, k = jnp.stack(fresh), jnp.stack(k)
    pick = k[:, None] == jnp.arange(K)[None]  # (M, K) one-hot selections, not gathers (cheaper under vmap) nor
    # matrix products (which GPUs may round to TF32)
    position = jnp.where(fresh[:, None], jnp.sum(jnp.where(pick[..., None], blob_centroid, 0.0), axis=1), position)
    velocity = jnp.where(fresh[:, None], 0.0, velocity)
    cov = jnp.where(fresh[:, None, None], jnp.sum(jnp.where(pick[..., None, None], blob_cov, 0.0), axis=1), cov)
    missed = jnp.where(fresh, 0, missed)
    hidden = jnp.where(fresh, 0, hidden)
    area = jnp.where(fresh, jnp.sum(jnp.where(pick, blob_area, 0.0), axis=1), meas.area)
    blob = jnp.where(fresh, k, jnp.where(observed, j, -1))
    acquired = state.acquired | fresh
    observed = observed | fresh
    lost = ~(acquired & (missed < opts.n_lost) & (hidden < opts.n_hidden))
    new = TrackState(position, velocity, cov, missed, hidden, acquired, started)
    out = Tracks(position, velocity, cov, jnp.where(observed, area, 0.0), blob, observed, shared, lost)
    return new, out


def initial_track_state(n_targets: int) -> TrackState:
    """The tracker's state before a video's first frame: M = `n_targets` targets, none acquired."""
    M = n_targets
    return TrackState(jnp.zeros((M, 2)), jnp.zeros((M, 2)), jnp.broadcast_to(jnp.eye(2), (M, 2, 2)),
                      jnp.zeros(M, jnp.int32), jnp.zeros(M, jnp.int32), jnp.zeros(M, bool), jnp.asarray(False))


def _track_video(opts: _Options, init: TrackState, labels, area, centroid, cov, valid) -> tuple[TrackState, Tracks]:
    return jax.lax.scan(partial(_step, opts), init, (labels, area, centroid, cov, valid))


_track_many = jax.jit(jax.vmap(_track_video, in_axes=(None, 0, 0, 0, 0, 0, 0)))


def _check_blobs(blobs: Blobs) -> tuple[int, ...]:
    """The leading (T,) or (B, T) shape of consistent `Blobs`; ValueError naming `blobs` otherwise."""
    if not isinstance(blobs, Blobs):
        raise ValueError(f"blobs: expected a hog_jax.video.Blobs (from connected_blobs), got {type(blobs).__name__}")
    labels = np.asarray(blobs.labels)
    if labels.ndim not in (3, 4) or 0 in labels.shape:
        raise ValueError(f"blobs: expected labels (T, H, W) or (B, T, H, W), got shape {labels.shape}")
    lead = labels.shape[:-2]
    K = np.shape(blobs.area)[-1] if np.ndim(blobs.area) == len(lead) + 1 else -1
    want = {"area": (*lead, K), "centroid": (*lead, K, 2), "cov": (*lead, K, 2, 2), "valid": (*lead, K)}
    for name, shape in want.items():
        if K < 1 or np.shape(getattr(blobs, name)) != shape:
            raise ValueError(f"blobs: {name} has shape {np.shape(getattr(blobs, name))}, expected {shape} "
                             f"for labels of shape {labels.shape}")
    if labels.min() < 0 or labels.max() > K:
        raise ValueError(f"blobs: labels must lie in [0, {K}] (0 background, k + 1 for slot k)")
    for name in ("area", "centroid", "cov"):
        as_array(getattr(blobs, name), f"blobs.{name}")
    return lead


def track(blobs: Blobs, init: tuple[str, ...] = ("top", "left_of_first", "right_of_first"),
          options: TrackOptions = TrackOptions()) -> Tracks:
    """Track blob ellipses through a video with α-β filters (LEVELSET TR §3.7; LfD 2009 §III-A).

    Per frame: predict each target at constant velocity; associate it with the gated blob whose
    pixel is nearest in the Mahalanobis distance of its own ellipse; measure (a blob shared by
    several targets is split by their ellipses, after Argyros & Lourakis, ECCV 2004, and a target
    with too little of it is concealed and coasts); correct by the α-β update; acquire untracked
    targets from the blobs no target took, by their `init` rule.

    Args:
        blobs: the connected components of a video (T, ...) or a batch (B, T, ...)
            (`connected_blobs`).
        init: one acquisition rule per target (M = len(init), from `INIT_RULES`), also the order of
            acquisition: "top" the highest centroid, "bottom", "left", "right", "largest";
            "left_of_first" / "right_of_first" the leftmost / rightmost blob beyond that side of
            target 0's ellipse (not for target 0). The default makes target 0 the face, 1 the hand
            left of it in the image (a facing person's right hand) and 2 the other hand.
        options: the tracker's options (`TrackOptions`).

    Returns:
        `Tracks` with the leading axes of the blobs, (T, M, ...) or (B, T, M, ...).

    Raises:
        ValueError: naming the argument for blobs that are not consistent `Blobs`, an empty `init`,
            an unknown rule, a side rule for target 0, options that are not a `TrackOptions`, or
            `options.min_init` above the blob slots K.
    """
    return track_chunk(blobs, None, init, options)[1]


def track_chunk(blobs: Blobs, state: TrackState | None,
                init: tuple[str, ...] = ("top", "left_of_first", "right_of_first"),
                options: TrackOptions = TrackOptions()) -> tuple[TrackState, Tracks]:
    """`track` on a chunk of frames from a given tracker state, for a video read chunk by chunk.

    Tracking the chunks of a video in order, each from the state the previous one returned (the
    first from None), gives the `Tracks` of `track` on the whole video.

    Args:
        blobs: the connected components of the chunk's frames, (T, ...) or (B, T, ...)
            (`connected_blobs`).
        state: the `TrackState` after the previous chunk (leading (B,) for a batch), or None before
            the first frame.
        init: the acquisition rules (`track`).
        options: the tracker's options (`TrackOptions`).

    Returns:
        (the `TrackState` after the chunk's last frame, the chunk's `Tracks` as `track` gives them).

    Raises:
        ValueError: as `track`, and naming `state` for one that is not a `TrackState` of M targets
            (and B videos).
    """
    lead = _check_blobs(blobs)
    init = (init,) if isinstance(init, str) else tuple(init)
    if not init:
        raise ValueError("init: expected one rule per target, got none")
    rules = [INIT_RULES.index(check_choice(r, f"init[{i}]", INIT_RULES)) for i, r in enumerate(init)]
    if init[0] in _SIDE_RULES:
        raise ValueError(f"init[0]: {init[0]!r} is relative to target 0 itself; give target 0 one of {INIT_RULES[:5]}")
    if not isinstance(options, TrackOptions):
        raise ValueError(f"options: expected a TrackOptions, got {type(options).__name__}")
    o = options
    K = int(np.shape(blobs.area)[-1])
    opts = _Options(
        jnp.float32(o.alpha), jnp.float32(o.beta), jnp.float32(o.dt), jnp.float32((2.0 * o.gate) ** 2),
        jnp.float32(o.cov_floor), jnp.int32(o.n_lost), jnp.int32(o.n_hidden),
        jnp.int32(check_int(len(init) if o.min_init is None else o.min_init, "min_init", min_value=1, max_value=K)),
        jnp.asarray(bool(o.reacquire)), jnp.float32(o.min_evidence), jnp.float32(o.merge_damping),
        jnp.asarray(rules, jnp.int32))
    arrays = (blobs.labels, blobs.area, blobs.centroid, blobs.cov, blobs.valid)
    batch = lead[:-1]
    if state is None:
        state = jax.tree.map(lambda x: jnp.broadcast_to(x, (*batch, *x.shape)), initial_track_state(len(init)))
    elif not isinstance(state, TrackState) or np.shape(state.position) != (*batch, len(init), 2):
        raise ValueError(f"state: expected a TrackState of {len(init)} targets with leading axes {batch}")
    if len(lead) == 2:
        return _track_many(opts, state, *arrays)
    state, tracks = _track_many(opts, jax.tree.map(lambda x: x[None], state), *(x[None] for x in arrays))
    return jax.tree.map(lambda x: x[0], state), jax.tree.map(lambda x: x[0], tracks)  # one program for both
