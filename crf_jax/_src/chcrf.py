"""Connected hierarchic CRFs ("late fusion", OAC eq. 8 / LfD eq. 9) and the object-history prior (LfD eq. 10).

    P(a, o | x) = K(a, o) P(a | x) P(o | x) / Z(x),   Z(x) = sum_{a, o} K(a, o) P(a | x) P(o | x)

K is the co-occurrence rate of action and object labels in the training data (`cooccurrence`,
with additive smoothing so that unseen pairs keep a small mass). P(a | x) and P(o | x) come from
any classifier that gives (log) probabilities: `segment_log_probs` (pre-segmented CRF,
eq. 3), `hcrf_log_probs` (eq. 5), `linear_log_proba`. The normaliser Z(x) is returned: LfD
uses it as the plausibility of an object-action complex (low for unseen combinations).
All arithmetic in log space; results are jax arrays in the compute dtype. Shapes: B batch, Ka actions, Ko objects, I history entries, P position dims.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from lfd_common import as_array, check_int, check_real, float_dtype, safe_logsumexp


class CHCRFResult(NamedTuple):
    """The fused distribution of `fuse` per row b (OAC eq. 8, LfD eq. 9).

    Where `impossible[b]` (K(a, o) P(a | x) P(o | x) = 0 for every pair: Z(x) = 0, no
    distribution), log_z[b] is -inf and log_joint, log_action, log_object are -inf everywhere in
    row b (never NaN).

    Attributes:
        log_joint: (B, Ka, Ko) log P(a, o | x).
        log_z: (B,) log Z(x) = log sum_{a,o} K(a, o) P(a | x) P(o | x), the plausibility of the
            object-action complex (LfD).
        log_action: (B, Ka) marginal log P(a | x) of the fused model.
        log_object: (B, Ko) marginal log P(o | x) of the fused model.
        impossible: (B,) Z(x) = 0: no (a, o) pair has positive mass.
    """

    log_joint: Float[Array, "B Ka Ko"]
    log_z: Float[Array, " B"]
    log_action: Float[Array, "B Ka"]
    log_object: Float[Array, "B Ko"]
    impossible: Bool[Array, " B"]


class HistoryPosterior(NamedTuple):
    """The result of `apply_history` (LfD eq. 10): one OAC's distribution given the scene's history.

    Attributes:
        log_joint: (Ka, Ko) log P(a, o | x, history), normalised.
        log_normaliser: () log sum_{a,o} P(a, o | x) prior(a, o).
    """

    log_joint: Float[Array, "Ka Ko"]
    log_normaliser: Float[Array, ""]


def _out(x) -> Array:
    return jnp.asarray(x, dtype=float_dtype())


def cooccurrence(actions: Int[ArrayLike, " N"], objects: Int[ArrayLike, " N"], n_actions: int, n_objects: int,
                 smoothing: float = 0.0) -> Float[Array, "Ka Ko"]:
    """The co-occurrence rates K(a, o) of action and object labels in training data (OAC eq. 8).

    K = (count(a, o) + smoothing) / sum: additive smoothing keeps a small mass on unseen pairs.

    Args:
        actions: (N,) action labels in [0, n_actions). N may be 0 when smoothing > 0 (K is then
            uniform).
        objects: (N,) the paired object labels in [0, n_objects).
        n_actions: Ka, >= 1.
        n_objects: Ko, >= 1.
        smoothing: Pseudo-count added to every pair, >= 0.

    Returns:
        (Ka, Ko) rates summing to 1, in the compute dtype.

    Raises:
        ValueError: Naming the argument: labels out of range or non-integral, `objects` of another
            length than `actions`, counts < 1, a negative smoothing; `actions` when there are no
            pairs and no smoothing (K undefined).
    """
    n_actions = check_int(n_actions, "n_actions", min_value=1)
    n_objects = check_int(n_objects, "n_objects", min_value=1)
    smoothing = check_real(smoothing, "smoothing", min_value=0.0)
    a = as_array(actions, "actions", ndim=1, dtype=np.int64, min_value=0, max_value=n_actions - 1,
                 nonempty=False)
    o = as_array(objects, "objects", ndim=1, dtype=np.int64, min_value=0, max_value=n_objects - 1,
                 nonempty=False)
    if a.shape != o.shape:
        raise ValueError(f"objects: expected {a.shape[0]} labels (one per action label), got {o.shape[0]}")
    if a.size == 0 and smoothing == 0.0:
        raise ValueError("actions: no training pairs and smoothing=0: the co-occurrence rates are undefined "
                         "(give pairs or smoothing > 0)")
    counts = np.zeros((n_actions, n_objects))
    np.add.at(counts, (a, o), 1.0)
    counts += smoothing
    return _out(counts / counts.sum())


def _row_peak(x: Array, axis) -> Array:
    """max over `axis` (keepdims), 0 where the slice is all -inf: a shift that keeps sums finite."""
    m = jnp.max(x, axis=axis, keepdims=True)
    return jnp.where(jnp.isfinite(m), m, 0.0)


@jax.jit
def fuse_jit(log_pa: Array, log_po: Array, log_k: Array) -> CHCRFResult:
    # shift each factor by its max first, so that large unnormalised scores cannot overflow the sum
    pa_peak, po_peak, k_peak = _row_peak(log_pa, 1), _row_peak(log_po, 1), _row_peak(log_k, (0, 1))
    joint = (log_k - k_peak)[None] + (log_pa - pa_peak)[:, :, None] + (log_po - po_peak)[:, None, :]
    # then by the joint's own row peak: where every product is tiny (rates near 1e-300 give log scores
    # near -700), joint - log Z would otherwise lose float32 digits to their common magnitude
    joint_peak = _row_peak(joint, (1, 2))
    joint = joint - joint_peak
    log_z_shifted = safe_logsumexp(joint.reshape(joint.shape[0], -1), axis=-1)
    impossible = log_z_shifted == -jnp.inf
    log_joint = jnp.where(impossible[:, None, None], -jnp.inf,
                          joint - jnp.where(impossible, 0.0, log_z_shifted)[:, None, None])
    log_z = log_z_shifted + joint_peak[:, 0, 0] + pa_peak[:, 0] + po_peak[:, 0] + k_peak[0, 0]
    return CHCRFResult(log_joint, log_z, safe_logsumexp(log_joint, axis=2), safe_logsumexp(log_joint, axis=1),
                       impossible)


def fuse(log_p_action: Float[ArrayLike, "B Ka"], log_p_object: Float[ArrayLike, "B Ko"],
         cooc: Float[ArrayLike, "Ka Ko"]) -> CHCRFResult:
    """Late fusion of action and object classifiers (connected hierarchic CRFs, OAC eq. 8, LfD eq. 9).

    P(a, o | x) = K(a, o) P(a | x) P(o | x) / Z(x), computed in log space. A row where
    K(a, o) P(a | x) P(o | x) = 0 for every pair has no fused distribution: it is flagged in
    `impossible`, with log_z = -inf and -inf log probabilities (see `CHCRFResult`).

    Args:
        log_p_action: (B, Ka) action log-probabilities, or unnormalised log scores (Z then carries
            their scale, as in LfD Fig. 8); -inf (probability 0) is allowed, NaN and +inf are not.
        log_p_object: (B, Ko) object log-probabilities or log scores, likewise.
        cooc: (Ka, Ko) co-occurrence rates K >= 0 (e.g. from `cooccurrence`).

    Returns:
        `CHCRFResult`: log_joint (B, Ka, Ko), log_z (B,), log_action (B, Ka), log_object (B, Ko),
        impossible (B,).

    Raises:
        ValueError: Naming the argument: NaN or +inf scores, finite values that overflow the
            compute dtype, batch sizes that differ (`log_p_object`), `cooc` of the wrong shape,
            negative or all zero.
    """
    dtype = float_dtype()
    la = _log_scores(log_p_action, "log_p_action", dtype)
    lo = _log_scores(log_p_object, "log_p_object", dtype)
    if la.shape[0] != lo.shape[0]:
        raise ValueError(f"log_p_object: batch of {lo.shape[0]} does not match the {la.shape[0]} action rows")
    k = as_array(cooc, "cooc", shape=(la.shape[1], lo.shape[1]), min_value=0.0)
    if k.sum() <= 0:
        raise ValueError("cooc: all co-occurrence rates are 0")
    with np.errstate(divide="ignore"):
        log_k = np.log(k)
    return fuse_jit(jnp.asarray(la, dtype), jnp.asarray(lo, dtype), jnp.asarray(log_k, dtype))


def _log_scores(value, name: str, dtype) -> np.ndarray:
    """(B, K) log scores: non-empty, no NaN or +inf, finite values within `dtype`'s range."""
    arr = as_array(value, name, ndim=2, finite=False)
    if np.any(np.isnan(arr)) or np.any(arr == np.inf):
        raise ValueError(f"{name}: contains NaN or +inf")
    finite = arr[np.isfinite(arr)]
    limit = np.finfo(dtype).max
    if finite.size and np.max(np.abs(finite)) > limit:
        raise ValueError(f"{name}: values up to {np.max(np.abs(finite)):.3g} overflow {np.dtype(dtype).name}")
    return arr


def history_prior(history: Float[ArrayLike, "I Ka Ko"], history_positions: Float[ArrayLike, "I P"],
                  position: Float[ArrayLike, " P"], default_distance: float,
                  min_distance: float = 1e-6) -> Float[Array, "Ka Ko"]:
    """The object-history prior of LfD eq. 10: (1 / (I + 1)) (P_0 / delta_0 + sum_i P_i / |p_i - p|).

    An object only moves when a person manipulates it, so the classification of each earlier
    object-action complex (OAC) of the scene weighs in inversely to the distance between where its
    hand ended and where the new OAC's hand starts.

    Args:
        history: (I, Ka, Ko) P(a, o | x) of the I earlier OACs of the scene (I may be 0), >= 0.
        history_positions: (I, P) the hand position at the end of each.
        position: (P,) the hand position at the start of the new OAC.
        default_distance: delta_0 > 0, weighting the "object not manipulated before" hypothesis
            with uniform P_0.
        min_distance: Distances are clipped below at this (> 0).

    Returns:
        (Ka, Ko) the prior, in the compute dtype.

    Raises:
        ValueError: Naming the argument: a distance not > 0, shapes that disagree, negative or
            NaN/inf entries, Ka or Ko of 0.
    """
    d0 = check_real(default_distance, "default_distance", min_value=0.0, exclusive_min=True)
    min_distance = check_real(min_distance, "min_distance", min_value=0.0, exclusive_min=True)
    hist = as_array(history, "history", ndim=3, min_value=0.0, nonempty=False)
    p = as_array(position, "position", ndim=1)
    pos = as_array(history_positions, "history_positions", shape=(hist.shape[0], p.shape[0]), nonempty=False)
    if hist.shape[1] == 0 or hist.shape[2] == 0:
        raise ValueError(f"history: expected shape (I, Ka, Ko) with Ka, Ko >= 1, got {hist.shape}")
    n = hist.shape[0]
    prior = np.full(hist.shape[1:], 1.0 / (hist.shape[1] * hist.shape[2])) / d0
    if n:
        dist = np.maximum(np.linalg.norm(pos - p[None], axis=1), min_distance)
        prior = prior + np.sum(hist / dist[:, None, None], axis=0)
    return _out(prior / (n + 1))


def apply_history(log_joint: Float[ArrayLike, "Ka Ko"], prior: Float[ArrayLike, "Ka Ko"]) -> HistoryPosterior:
    """Combine one OAC's fused distribution with the history prior (LfD eq. 10).

    P(a, o | x, history) ∝ P(a, o | x) * prior.

    Args:
        log_joint: (Ka, Ko) log P(a, o | x) (e.g. a row of `fuse`'s log_joint); -inf allowed, not
            everywhere.
        prior: (Ka, Ko) the prior >= 0 (from `history_prior`).

    Returns:
        `HistoryPosterior`: the normalised log_joint (Ka, Ko) and the log normaliser ().

    Raises:
        ValueError: Naming the argument: NaN or +inf, all -inf (`log_joint`); a shape other than
            log_joint's, negative entries, or zero on every pair log_joint allows (`prior`).
    """
    lj = _log_scores(log_joint, "log_joint", np.float64)
    if not np.any(np.isfinite(lj)):
        raise ValueError("log_joint: every (action, object) pair has probability 0 (all -inf)")
    pr = as_array(prior, "prior", shape=lj.shape, min_value=0.0)
    with np.errstate(divide="ignore"):
        s = lj + np.log(pr)
    m = np.max(s)
    if not np.isfinite(m):
        raise ValueError("prior: gives zero probability to every (action, object) pair the log_joint allows")
    log_norm = m + np.log(np.sum(np.exp(s - m)))
    return HistoryPosterior(_out(s - log_norm), _out(log_norm))
