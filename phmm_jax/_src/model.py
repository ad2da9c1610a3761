"""The left-right Gaussian HMM with explicit state durations (pseudo-state chains, PHMM Fig. 3).

Every state i in 0..N-1 is a chain of P pseudo-states sharing state i's Gaussian. Entering state i
puts the path on pseudo-state (i, 0); pseudo-state (i, j) means "the (j+1)-th step in state i".
From (i, j) the path either *continues* to (i, j+1) — to itself when j = P-1 — or *exits* to (i+1, 0);
exiting the last state ends the sequence. So a pseudo-state has at most two successors, and one
step of inference costs O(N·P), not O((N·P)^2).

* Explicit durations (`max_duration` set): P = max_duration; exit is allowed only once the state
  has lasted `min_duration` steps, and (i, P-1) must exit. A path stays in each state between
  `min_duration` and `max_duration` steps, and the duration distribution p_i(d) is learned.
* Classical left-right HMM (`max_duration=None`, the papers' baseline): P = min_duration, the last
  pseudo-state loops on itself (geometric duration after the minimum); with `min_duration=1` this is
  the ordinary left-right HMM with self-loops.

Paths start in (0, 0) and must end by exiting state N-1: the end constraint and the last state's
duration are part of the likelihood. Forbidden transitions are exactly -inf in log space and stay so.
"""
from __future__ import annotations

import dataclasses
from functools import partial
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from lfd_common import NEG_INF, check_choice, check_int, safe_log


@dataclasses.dataclass(frozen=True)
class HMMConfig:
    """The static structure of a left-right (explicit-duration) Gaussian HMM: what defines the model.

    PHMM §III-B1 and Fig. 3: each state is a chain of pseudo-states sharing its Gaussian, so a path
    stays between `min_duration` and `max_duration` steps in it (the papers use 20 states and
    durations 4-6, BMVC §5.1). It is hashable (the `HMM` pytree carries it as static metadata, so
    jitted functions specialise on it) and is saved with the model; how a model is fitted is not
    part of it (`FitOptions`).

    Attributes:
        n_states: N, the number of states (each with one Gaussian), >= 1.
        min_duration: Steps a path stays in each state at least, >= 1.
        max_duration: Steps a path stays in each state at most (>= min_duration); None gives the
            classical left-right HMM with self-loops (geometric durations of at least
            `min_duration`).
        covariance_type: "full" (default) or "diag" (diagonal matrices, still stored as (N, D, D)).

    Raises:
        ValueError: Naming the field, for a non-integer or out-of-range count, min_duration >
            max_duration, or an unknown covariance_type.
    """

    n_states: int = 20
    min_duration: int = 1
    max_duration: int | None = None
    covariance_type: str = "full"

    def __post_init__(self):
        check_int(self.n_states, "n_states", min_value=1)
        check_int(self.min_duration, "min_duration", min_value=1)
        if self.max_duration is not None:
            check_int(self.max_duration, "max_duration", min_value=1)
            if self.min_duration > self.max_duration:
                raise ValueError(
                    f"min_duration: must be <= max_duration, got {self.min_duration} > {self.max_duration}")
        check_choice(self.covariance_type, "covariance_type", ("full", "diag"))

    @property
    def explicit_duration(self) -> bool:
        """Whether the durations are explicit (`max_duration` set) rather than geometric."""
        return self.max_duration is not None

    @property
    def n_pseudo(self) -> int:
        """P, pseudo-states per state."""
        return self.max_duration if self.explicit_duration else self.min_duration

    @property
    def min_length(self) -> int:
        """The shortest sequence a path can explain: every state for `min_duration` steps."""
        return self.n_states * self.min_duration

    @property
    def max_length(self) -> int | None:
        """The longest sequence a path can explain (None: unbounded)."""
        return self.n_states * self.max_duration if self.explicit_duration else None


@partial(jax.tree_util.register_dataclass,
         data_fields=["means", "covariances", "log_cont", "log_exit"], meta_fields=["config"])
@dataclasses.dataclass(frozen=True)
class HMM:
    """A left-right Gaussian HMM over pseudo-state chains (PHMM §III-A, §III-B1, Fig. 3).

    An immutable pytree whose structure (`config`) is static metadata. A `PHMM` stacks several of
    them along a leading axis C.

    Attributes:
        means: (N, D) state means.
        covariances: (N, D, D) state covariances (diagonal matrices for covariance_type "diag").
        log_cont: (N, P) log-probability of continuing from pseudo-state (i, j) to (i, j+1) (to
            itself for j = P-1); -inf where the structure forbids it.
        log_exit: (N, P) log-probability of exiting state i from pseudo-state (i, j); -inf where
            forbidden.
        config: The `HMMConfig`, the static structure (N, durations, covariance type).
    """

    means: jnp.ndarray
    covariances: jnp.ndarray
    log_cont: jnp.ndarray
    log_exit: jnp.ndarray
    config: HMMConfig

    @property
    def n_states(self) -> int:
        """N, the number of states."""
        return self.config.n_states

    @property
    def dim(self) -> int:
        """D, the feature dimension."""
        return self.means.shape[-1]

    def replace(self, **changes: Any) -> "HMM":
        """A copy with some fields replaced (no checks: the arrays must keep their shapes).

        Args:
            **changes: Field names and their new values.

        Returns:
            The new `HMM`.
        """
        return dataclasses.replace(self, **changes)


def allowed_transitions(config: HMMConfig) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks (P,) of the pseudo-states that may continue, and that may exit."""
    j = np.arange(config.n_pseudo)
    may_exit = j >= config.min_duration - 1
    may_continue = j < config.n_pseudo - 1 if config.explicit_duration else np.ones_like(may_exit)
    return may_continue, may_exit


def reachable_states(config: HMMConfig, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(first, last) (T,) int: the states in which a path that starts at frame 0 and ends by frame
    T-1 (any length L <= T) can be at frame t = 0..T-1.

    Before state i the path spent between `min_duration` and `max_duration` steps in each of the i
    states, so i <= t // min_duration and, with explicit durations, (i + 1) max_duration >= t + 1.
    After it, states i+1..N-1 need `min_duration` steps each before the end at L - 1 <= T - 1, so
    i >= N - 1 - (T - 1 - t) // min_duration (a bound that holds for every L <= T, so one band serves
    a padded batch). Every other state has forward or backward probability zero at frame t, whatever
    the data, and posterior zero.
    """
    t = np.arange(n_frames)
    last = np.minimum(config.n_states - 1, t // config.min_duration)
    first = config.n_states - 1 - (n_frames - 1 - t) // config.min_duration
    if config.explicit_duration:
        first = np.maximum(first, -(-(t + 1) // config.max_duration) - 1)
    return np.clip(first, 0, last), last


def state_band(config: HMMConfig, n_frames: int) -> tuple[np.ndarray, int]:
    """(start (T,) int, width W): the band of states start[t]..start[t] + W - 1 that holds every
    `reachable_states` state at frame t, for the banded forward recursion (`inference`).

    start never decreases and moves by at most one state per frame (both bounds of
    `reachable_states` do), and start[t] <= N - W, so the band never leaves the model.
    """
    first, last = reachable_states(config, n_frames)
    width = int(np.max(last - first + 1))
    return np.minimum(first, config.n_states - width), width


def transitions_from_counts(config: HMMConfig, cont_counts, exit_counts, pseudocount,
                            previous: HMM | None = None):
    """Maximum-likelihood (log_cont, log_exit) (N, P) from expected counts (N, P) (the M step of the
    pseudo-state chains), with a Dirichlet `pseudocount` on every allowed transition.

    The pseudo-count is added to allowed transitions only, so forbidden ones stay exactly -inf.
    Pseudo-states never visited (zero total) keep `previous`'s values (uniform when None).
    """
    may_continue, may_exit = allowed_transitions(config)
    cont = jnp.where(may_continue, cont_counts + pseudocount, 0.0)
    exit_ = jnp.where(may_exit, exit_counts + pseudocount, 0.0)
    total = cont + exit_
    visited = total > 0
    safe_total = jnp.where(visited, total, 1.0)
    log_cont = safe_log(cont / safe_total)
    log_exit = safe_log(exit_ / safe_total)
    if previous is None:
        n_allowed = may_continue.astype(float) + may_exit.astype(float)
        fallback_cont = jnp.where(may_continue, -jnp.log(n_allowed), NEG_INF)
        fallback_exit = jnp.where(may_exit, -jnp.log(n_allowed), NEG_INF)
    else:
        fallback_cont, fallback_exit = previous.log_cont, previous.log_exit
    return jnp.where(visited, log_cont, fallback_cont), jnp.where(visited, log_exit, fallback_exit)


def transitions_from_durations(config: HMMConfig, log_duration_probs: Float[Array, "N P"]
                               ) -> tuple[Float[Array, "N P"], Float[Array, "N P"]]:
    """Pseudo-state transitions that give each state a chosen duration distribution (PHMM Fig. 3).

    The hazard of leaving after d steps, given d steps were reached, is p(d) / sum_{d' >= d} p(d').
    Forbidden transitions stay exactly -inf. Pure jnp, differentiable.

    Args:
        config: The structure; it must have explicit durations (`max_duration` set).
        log_duration_probs: (N, P) log p_i(d) over d = 1..P (P = max_duration).

    Returns:
        (log_cont, log_exit), each (N, P).

    Raises:
        ValueError: Naming `config`, when its durations are not explicit.
    """
    if not config.explicit_duration:
        raise ValueError("config: durations as a distribution need max_duration (explicit durations)")
    survive = _reverse_logcumsumexp(log_duration_probs)  # log P(D >= d)
    survive_next = jnp.concatenate([survive[:, 1:], jnp.full_like(survive[:, :1], NEG_INF)], axis=1)
    reachable = jnp.isfinite(survive)
    safe_survive = jnp.where(reachable, survive, 0.0)
    log_exit = jnp.where(reachable, log_duration_probs - safe_survive, NEG_INF)
    log_cont = jnp.where(reachable, survive_next - safe_survive, NEG_INF)
    may_continue, may_exit = allowed_transitions(config)
    return jnp.where(may_continue, log_cont, NEG_INF), jnp.where(may_exit, log_exit, NEG_INF)


def duration_log_probs(hmm: HMM) -> Float[Array, "N P"]:
    """log p_i(d) (N, P) of the chain's duration distribution for d = 1..P (for a classical HMM,
    the probability of lasting exactly d steps, the geometric tail beyond P not included)."""
    reach = jnp.concatenate(
        [jnp.zeros_like(hmm.log_cont[:, :1]), jnp.cumsum(hmm.log_cont[:, :-1], axis=1)], axis=1)
    return reach + hmm.log_exit


def expected_durations(hmm: HMM) -> Float[Array, " N"]:
    """Expected number of steps spent in each state, from the pseudo-state transitions.

    Synthesis places the state means at the centres of these durations (PHMM §III-B2).

    Args:
        hmm: One model (log_cont (N, P)).

    Returns:
        (N,) expected durations in frames, including a classical chain's geometric tail.
    """
    p = jnp.exp(duration_log_probs(hmm))
    d = jnp.arange(1, hmm.log_cont.shape[1] + 1, dtype=p.dtype)
    within = jnp.sum(p * d, axis=1)
    # Classical chain: probability mass still in the self-loop at d = P continues geometrically.
    stay = jnp.exp(hmm.log_cont[:, -1])
    reach_last = jnp.exp(jnp.sum(hmm.log_cont[:, :-1], axis=1))
    safe = jnp.where(stay < 1.0, 1.0 - stay, 1.0)
    tail = jnp.where(stay > 0, reach_last * stay * (d[-1] + 1.0 / safe), 0.0)
    return within + tail


def _reverse_logcumsumexp(a):
    # In probability space: durations are few, and log 0 must keep a finite gradient.
    return safe_log(jnp.flip(jnp.cumsum(jnp.flip(jnp.exp(a), axis=-1), axis=-1), axis=-1))


def log_final(hmm: HMM) -> jnp.ndarray:
    """(N, P) log-weight of ending the sequence on each pseudo-state: exiting the last state."""
    n_states = hmm.log_exit.shape[0]
    last = jnp.arange(n_states)[:, None] == n_states - 1
    return jnp.where(last, hmm.log_exit, NEG_INF)


class DenseHMM(NamedTuple):
    """An ordinary HMM over the S = N·P pseudo-states, equivalent to an `HMM` (see `expand_to_dense`).

    Attributes:
        log_initial: (S,) log initial probabilities.
        log_transition: (S, S) log transition probabilities, row = from.
        log_final: (S,) end weights: the likelihood is logsumexp(alpha_T + log_final); libraries
            without end states must add it.
        means: (S, D), each pseudo-state repeating its state's mean.
        covariances: (S, D, D), each pseudo-state repeating its state's covariance.
        state_of: (S,) the state index of each pseudo-state.
    """

    log_initial: np.ndarray
    log_transition: np.ndarray
    log_final: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    state_of: np.ndarray


def expand_to_dense(hmm: HMM) -> DenseHMM:
    """The equivalent ordinary HMM over the pseudo-states (PHMM Fig. 3), for dense HMM libraries.

    Args:
        hmm: One model (not a PHMM's stack of local models).

    Returns:
        `DenseHMM` over the S = N·P pseudo-states (index s = i·P + j), as float64 numpy arrays.

    Raises:
        ValueError: Naming `hmm`, when it is not one `HMM`.
    """
    if not isinstance(hmm, HMM) or np.ndim(hmm.log_cont) != 2:
        raise ValueError(f"hmm: expected one phmm_jax.HMM, got {type(hmm).__name__}")
    log_cont = np.asarray(hmm.log_cont, np.float64)
    log_exit = np.asarray(hmm.log_exit, np.float64)
    n_states, n_pseudo = log_cont.shape
    size = n_states * n_pseudo
    trans = np.full((size, size), -np.inf)
    for i in range(n_states):
        for j in range(n_pseudo):
            s = i * n_pseudo + j
            trans[s, i * n_pseudo + min(j + 1, n_pseudo - 1)] = log_cont[i, j]
            if i + 1 < n_states:
                trans[s, (i + 1) * n_pseudo] = log_exit[i, j]
    initial = np.full(size, -np.inf)
    initial[0] = 0.0
    state_of = np.repeat(np.arange(n_states), n_pseudo)
    return DenseHMM(
        log_initial=initial,
        log_transition=trans,
        log_final=np.asarray(log_final(hmm), np.float64).reshape(size),
        means=np.asarray(hmm.means, np.float64)[state_of],
        covariances=np.asarray(hmm.covariances, np.float64)[state_of],
        state_of=state_of,
    )
