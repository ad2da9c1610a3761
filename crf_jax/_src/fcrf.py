"""Factorial CRF with two coupled chains, actions a_t and objects o_t (OAC eq. 7, "early fusion").

    log P(a, o | x) = sum_t [ua_t(a_t) + uo_t(o_t) + coupling[a_t, o_t]]
                      + sum_{t>=1} [Ta[a_{t-1}, a_t] + To[o_{t-1}, o_t]] - log Z(x)

ua, uo are the node potentials of two `ChainCRF`s on the same features X (concatenate the action
and object features), Ta, To their transitions. Inference, two ways:

* "exact": a linear chain over the product space (Ka * Ko states), O(T (Ka Ko)^2); for small
  label sets (the papers have 3 x 3).
* "loopy": loopy belief propagation on the 2 x T ladder with a chain schedule: given the
  cross messages, each chain's messages are computed exactly by forward-backward; then new cross
  messages are sent; `n_iter` rounds (log space, optional damping). log Z is the Bethe
  approximation, marginals are the beliefs. Exact when the graph is a tree (e.g. T = 1, or
  one chain's transitions constant), which the tests check against "exact".

Shapes: B batch, T time, D features, Ka / Ko action / object labels.
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Int

from crf_jax._src import inference as inference
from crf_jax._src.checks import check_batch
from crf_jax._src.layout import check_fields
from crf_jax._src.chain import ChainCRF, init_chain, unary_potentials
from lfd_common import check_choice, check_int, safe_logsumexp


@dataclasses.dataclass(frozen=True)
class FCRFStructure:
    """What defines a factorial CRF (OAC eq. 7): what a saved model's file stores as JSON.

    Attributes:
        n_actions: Ka, action labels, >= 1.
        n_objects: Ko, object labels, >= 1.
        n_features: D, features per frame, >= 1.
        connectivity: C >= 0, one for both chains.

    Raises:
        ValueError: Naming the field, for a non-integer or a value below its minimum.
    """

    n_actions: int
    n_objects: int
    n_features: int
    connectivity: int = 0

    def __post_init__(self):
        check_fields(self, n_actions=1, n_objects=1, n_features=1, connectivity=0)


class FCRF(NamedTuple):
    """Factorial CRF parameters (a pytree; OAC eq. 7, "early fusion"): two coupled chains.

    Both chains read the same features with the same window (connectivity).

    Attributes:
        action: `ChainCRF` of the Ka action labels.
        object: `ChainCRF` of the Ko object labels.
        coupling: (Ka, Ko) log potential of each (action, object) pair at a frame.
    """

    action: ChainCRF
    object: ChainCRF
    coupling: Float[Array, "Ka Ko"]

    @property
    def n_features(self) -> int:
        """D, features per frame."""
        return self.action.n_features

    @property
    def structure(self) -> FCRFStructure:
        """The `FCRFStructure` that defines this model."""
        return FCRFStructure(self.action.n_labels, self.object.n_labels, self.n_features, self.action.connectivity)


class FCRFMarginals(NamedTuple):
    """Per-frame marginals (beliefs, for loopy BP) of the two chains of an FCRF, 0 on padding.

    Attributes:
        action: (B, T, Ka) P(a_t = a | x).
        object: (B, T, Ko) P(o_t = o | x).
    """

    action: Float[Array, "B T Ka"]
    object: Float[Array, "B T Ko"]


class SegmentLabels(NamedTuple):
    """The most probable (action, object) label of each pre-segmented sequence.

    Attributes:
        action: (B,) action labels.
        object: (B,) object labels.
    """

    action: Int[Array, " B"]
    object: Int[Array, " B"]


def init_fcrf(n_features: int, n_actions: int, n_objects: int, connectivity: int = 0,
              dtype: jnp.dtype = jnp.float32) -> FCRF:
    """All-zero starting parameters of a factorial CRF (no input checks).

    Args:
        n_features: D, features per frame.
        n_actions: Ka, action labels.
        n_objects: Ko, object labels.
        connectivity: C, for both chains.
        dtype: The arrays' dtype.

    Returns:
        `FCRF` with two zero `ChainCRF`s and a zero coupling (Ka, Ko).
    """
    return FCRF(init_chain(n_features, n_actions, connectivity, dtype=dtype),
                init_chain(n_features, n_objects, connectivity, dtype=dtype),
                jnp.zeros((n_actions, n_objects), dtype))


# ----------------------------------------------------------------------------------------------
# exact inference in the product space
# ----------------------------------------------------------------------------------------------
def product_potentials(ua: Array, uo: Array, Ta: Array, To: Array, coupling: Array) -> tuple[Array, Array]:
    """Product-space chain: unary (..., T, Ka * Ko) and trans (Ka * Ko, Ka * Ko); state (a, o) -> a * Ko + o."""
    Ka, Ko = coupling.shape
    unary = ua[..., :, None] + uo[..., None, :] + coupling
    trans = Ta[:, None, :, None] + To[None, :, None, :]
    return unary.reshape(unary.shape[:-2] + (Ka * Ko,)), trans.reshape(Ka * Ko, Ka * Ko)


@jax.jit
def exact_log_partition(ua, uo, Ta, To, coupling, lengths) -> Array:
    """log Z (B,) for ua (B, T, Ka), uo (B, T, Ko)."""
    unary, trans = product_potentials(ua, uo, Ta, To, coupling)
    return inference.log_partition(unary, trans, lengths)


@jax.jit
def exact_marginals(ua, uo, Ta, To, coupling, lengths) -> FCRFMarginals:
    """Node marginals (B, T, Ka), (B, T, Ko) of the product chain (0 on padding)."""
    Ka, Ko = coupling.shape
    unary, trans = product_potentials(ua, uo, Ta, To, coupling)
    node = inference.marginals(unary, trans, lengths).node.reshape(ua.shape[:2] + (Ka, Ko))
    return FCRFMarginals(node.sum(-1), node.sum(-2))


# ----------------------------------------------------------------------------------------------
# loopy belief propagation
# ----------------------------------------------------------------------------------------------
class BPResult(NamedTuple):
    log_z: Array  # (B,) Bethe approximation of log Z
    action: Array  # (B, T, Ka) node beliefs
    object: Array  # (B, T, Ko) node beliefs


def _normalize(log_m: Array) -> Array:
    """Normalise log messages. The normaliser is differentiated too: with a stop_gradient, a constant
    shift of the messages (which BP ignores) would be amplified ~(T - 1) times per round in the
    backward pass of the unrolled iterations and the gradients would explode."""
    return log_m - safe_logsumexp(log_m, axis=-1)[..., None]


def _xlogx(log_b: Array) -> Array:
    """b log b with b = exp(log_b), 0 where b = 0 (double where: no NaN value or gradient)."""
    pos = log_b != -jnp.inf  # NaN stays NaN
    safe = jnp.where(pos, log_b, 0.0)
    return jnp.where(pos, jnp.exp(safe) * safe, 0.0)


def _chain_beliefs(node_pot: Array, trans: Array, lengths: Array):
    """Forward-backward on a chain with node log potentials (B, T, K): log alpha, log beta, log pair beliefs."""
    alpha, beta, log_z = inference.forward_backward(node_pot, trans, lengths)
    pair = alpha[:, :-1, :, None] + trans + (node_pot[:, 1:] + beta[:, 1:])[:, :, None, :] - log_z[:, None, None, None]
    return alpha, beta, log_z, pair


@partial(jax.jit, static_argnames=("n_iter",))
def loopy_bp(ua: Array, uo: Array, Ta: Array, To: Array, coupling: Array, lengths: Array,
             n_iter: int = 20, damping: float = 0.0) -> BPResult:
    """Loopy BP (sum-product, log space) on the FCRF ladder; ua (B, T, Ka), uo (B, T, Ko)."""
    B, T, Ka = ua.shape
    valid = (jnp.arange(T)[None, :] < lengths[:, None])[..., None]  # (B, T, 1)
    ua = jnp.where(valid, ua, 0.0)
    uo = jnp.where(valid, uo, 0.0)

    def cavity_to_msg(cav: Array, coup: Array) -> Array:
        # message into the other chain: logsumexp_x (cav[t, x] + coup[x, y])
        return _normalize(safe_logsumexp(cav[..., :, None] + coup, axis=-2))

    def round_(m_oa, _):
        alpha, beta, _, _ = _chain_beliefs(ua + m_oa, Ta, lengths)
        m_ao = cavity_to_msg(alpha + beta - m_oa, coupling)
        alpha, beta, _, _ = _chain_beliefs(uo + m_ao, To, lengths)
        m_oa_new = cavity_to_msg(alpha + beta - m_ao, coupling.T)
        m_oa = _normalize((1 - damping) * m_oa_new + damping * m_oa)
        return m_oa, None

    m_oa0 = jnp.full((B, T, Ka), -jnp.log(Ka), ua.dtype)
    m_oa, _ = jax.lax.scan(round_, m_oa0, None, length=n_iter)
    # final messages and beliefs
    na = ua + m_oa
    alpha_a, beta_a, _, pair_a = _chain_beliefs(na, Ta, lengths)
    cav_a = alpha_a + beta_a - m_oa
    m_ao = cavity_to_msg(cav_a, coupling)
    no = uo + m_ao
    alpha_o, beta_o, _, pair_o = _chain_beliefs(no, To, lengths)
    cav_o = alpha_o + beta_o - m_ao

    def log_norm(x, n_axes):  # normalise over the last n_axes axes
        flat = x.reshape(x.shape[:2] + (-1,))
        return x - safe_logsumexp(flat, axis=-1).reshape(x.shape[:2] + (1,) * n_axes)

    # node beliefs of a from (ua, m_oa, a-chain messages), of o from (uo, m_ao, o-chain messages);
    # cross-pair beliefs from both cavities (at a fixed point these sets of messages agree)
    ba = log_norm(alpha_a + beta_a, 1)
    bo = log_norm(alpha_o + beta_o, 1)
    bc = log_norm(cav_a[..., :, None] + coupling + cav_o[..., None, :], 2)  # (B, T, Ka, Ko)
    pair_valid = (jnp.arange(1, T)[None, :] < lengths[:, None])[..., None, None]
    tv = valid[..., 0]

    def energy_entropy(log_b, log_psi, mask):  # sum over masked factors of E_b[log psi] + H(b)
        ok = (log_psi != -jnp.inf) & (log_b != -jnp.inf)  # NaN stays NaN
        e = jnp.where(ok, jnp.exp(jnp.where(ok, log_b, 0.0)) * jnp.where(ok, log_psi, 0.0), 0.0)
        val = e - _xlogx(log_b)
        return jnp.sum(jnp.where(mask, val, 0.0), axis=tuple(range(1, val.ndim)))

    Ta_b = jnp.broadcast_to(Ta, pair_a.shape)
    To_b = jnp.broadcast_to(To, pair_o.shape)
    total = (energy_entropy(pair_a, Ta_b, pair_valid) + energy_entropy(pair_o, To_b, pair_valid)
             + energy_entropy(bc, jnp.broadcast_to(coupling, bc.shape), tv[..., None, None]))
    # node terms: E[log phi] - (d - 1) H(b);  d = 1 (cross) + number of chain neighbours
    n_nb = (jnp.arange(T)[None, :] > 0).astype(ua.dtype) + (jnp.arange(T)[None, :] < lengths[:, None] - 1)
    d_minus_1 = n_nb[..., None]  # (B, T, 1): (1 + n_nb) - 1

    def node_terms(log_b, u):
        val = jnp.exp(log_b) * u + d_minus_1 * _xlogx(log_b)  # -(d-1) H = (d-1) sum b log b
        return jnp.sum(jnp.where(valid, val, 0.0), axis=(1, 2))

    log_z = total + node_terms(ba, ua) + node_terms(bo, uo)
    return BPResult(log_z, jnp.where(valid, jnp.exp(ba), 0.0), jnp.where(valid, jnp.exp(bo), 0.0))


# ----------------------------------------------------------------------------------------------
# the model on batches
# ----------------------------------------------------------------------------------------------
def _potentials(model: FCRF, X: Array, lengths: Array):
    ua = unary_potentials(model.action, X, lengths)
    uo = unary_potentials(model.object, X, lengths)
    return ua, uo, model.action.trans, model.object.trans, model.coupling


def log_partition(model: FCRF, X: Array, lengths: Array, method: str = "exact", n_iter: int = 20) -> Array:
    """log Z(x) (B,): exact (product space) or the Bethe approximation of loopy BP."""
    pots = _potentials(model, X, lengths)
    if method == "exact":
        return exact_log_partition(*pots, lengths)
    if method == "loopy":
        return loopy_bp(*pots, lengths, n_iter=n_iter).log_z
    raise ValueError(f"method: expected 'exact' or 'loopy', got {method!r}")


def score(model: FCRF, X: Array, ya: Array, yo: Array, lengths: Array) -> Array:
    """Unnormalised log score (B,) of label sequences ya, yo (B, T)."""
    ua, uo, Ta, To, coupling = _potentials(model, X, lengths)
    sa = jax.vmap(inference.sequence_score, (0, None, 0, 0))(ua, Ta, ya, lengths)
    so = jax.vmap(inference.sequence_score, (0, None, 0, 0))(uo, To, yo, lengths)
    valid = jnp.arange(X.shape[1])[None, :] < lengths[:, None]
    sc = jnp.sum(jnp.where(valid, coupling[jnp.where(valid, ya, 0), jnp.where(valid, yo, 0)], 0.0), axis=1)
    return sa + so + sc


@partial(jax.jit, static_argnames=("method", "n_iter"))
def nll(model: FCRF, X, ya, yo, lengths, method: str = "exact", n_iter: int = 20) -> Array:
    """-log P(a, o | x) per sequence (B,) (approximate with method="loopy")."""
    return log_partition(model, X, lengths, method, n_iter) - score(model, X, ya, yo, lengths)


@partial(jax.jit, static_argnames=("method", "n_iter"))
def marginals_jit(model: FCRF, X, lengths, method: str = "exact", n_iter: int = 20):
    pots = _potentials(model, X, lengths)
    if method == "exact":
        return exact_marginals(*pots, lengths)
    bp = loopy_bp(*pots, lengths, n_iter=n_iter)
    return FCRFMarginals(bp.action, bp.object)


@partial(jax.jit, static_argnames=("method", "n_iter"))
def segment_log_probs_jit(model: FCRF, X, lengths, method: str = "exact", n_iter: int = 20) -> Array:
    """Pre-segmented: log P(a_t = a, o_t = o for all t | x), (B, Ka, Ko)."""
    ua, uo, Ta, To, coupling = _potentials(model, X, lengths)
    valid = (jnp.arange(X.shape[1])[None, :] < lengths[:, None])[..., None]
    sa = jnp.sum(jnp.where(valid, ua, 0.0), axis=1)
    so = jnp.sum(jnp.where(valid, uo, 0.0), axis=1)
    steps = (lengths - 1)[:, None, None]
    path = (sa[:, :, None] + so[:, None, :] + lengths[:, None, None] * coupling
            + steps * (jnp.diagonal(Ta)[:, None] + jnp.diagonal(To)[None, :]))
    # a log probability (<= 0; float32 rounding of two large terms could exceed it). With "loopy" the
    # Bethe log Z is an approximation, so the values are approximate too.
    return jnp.minimum(path - log_partition(model, X, lengths, method, n_iter)[:, None, None], 0.0)


def _prepare(model: FCRF, X, lengths, method, n_iter):
    check_choice(method, "method", ("exact", "loopy"))
    check_int(n_iter, "n_iter", min_value=1)
    Xc, lens = check_batch(X, lengths, n_features=model.n_features)
    return jnp.asarray(Xc), jnp.asarray(lens)


def predict_marginals(model: FCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None,
                      method: str = "exact", n_iter: int = 20) -> FCRFMarginals:
    """Per-frame marginals of the action and object chains (OAC eq. 7).

    Args:
        model: The fitted `FCRF`.
        X: (B, T, D) padded features (the action and object features concatenated).
        lengths: (B,) frames per sequence in [1, T], or None (all T).
        method: "exact" (product space) or "loopy" (loopy belief propagation).
        n_iter: Rounds of loopy BP, >= 1 (unused with "exact").

    Returns:
        `FCRFMarginals`: action (B, T, Ka), object (B, T, Ko), 0 on padding (beliefs with
        method="loopy").

    Raises:
        ValueError: Naming the argument: `method` not "exact" or "loopy", `n_iter` < 1, `X` not
            (B, T, D) with the model's D, NaN/inf on real frames, an empty batch; `lengths`
            outside [1, T].
    """
    Xj, lj = _prepare(model, X, lengths, method, n_iter)
    return marginals_jit(model, Xj, lj, method, n_iter)


def segment_log_probs(model: FCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None,
                      method: str = "exact", n_iter: int = 20) -> Float[Array, "B Ka Ko"]:
    """Pre-segmented joint classification (OAC eq. 7): log P(a_t = a, o_t = o for all t | x).

    Args:
        model: The fitted `FCRF`.
        X: (B, T, D) padded features (the action and object features concatenated).
        lengths: (B,) frames per sequence in [1, T], or None (all T).
        method: "exact" (product space) or "loopy" (loopy belief propagation).
        n_iter: Rounds of loopy BP, >= 1 (unused with "exact").

    Returns:
        (B, Ka, Ko) log-probabilities, at most 0 (approximate with method="loopy", whose log Z is
        the Bethe approximation).

    Raises:
        ValueError: Naming the argument: `method` not "exact" or "loopy", `n_iter` < 1, `X` not
            (B, T, D) with the model's D, NaN/inf on real frames, an empty batch; `lengths`
            outside [1, T].
    """
    Xj, lj = _prepare(model, X, lengths, method, n_iter)
    return segment_log_probs_jit(model, Xj, lj, method, n_iter)


def predict_segments(model: FCRF, X: Float[ArrayLike, "B T D"], lengths: Int[ArrayLike, " B"] | None = None,
                     method: str = "exact", n_iter: int = 20) -> SegmentLabels:
    """The most probable (action, object) pair of every pre-segmented sequence (OAC eq. 7).

    Args:
        model: The fitted `FCRF`.
        X: (B, T, D) padded features (the action and object features concatenated).
        lengths: (B,) frames per sequence in [1, T], or None (all T).
        method: "exact" (product space) or "loopy" (loopy belief propagation).
        n_iter: Rounds of loopy BP, >= 1 (unused with "exact").

    Returns:
        `SegmentLabels`: action (B,), object (B,).

    Raises:
        ValueError: Naming the argument: `method` not "exact" or "loopy", `n_iter` < 1, `X` not
            (B, T, D) with the model's D, NaN/inf on real frames, an empty batch; `lengths`
            outside [1, T].
    """
    lp = segment_log_probs(model, X, lengths, method, n_iter)
    flat = jnp.argmax(lp.reshape(lp.shape[0], -1), axis=1)
    return SegmentLabels(flat // lp.shape[2], flat % lp.shape[2])
