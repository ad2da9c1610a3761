""""Object in hand" per frame from the look of the hand's neighbourhood: a logistic regression on the HOG
of a window around the tracked hand, trained on the pre-segmented clips of other persons (the renderer
says in which frames the hand holds the object), for LfD 2009 §III-D's temporal segmentation.

Why a second classification beside the paper's (a frame is "object in hand" where the phase-difference
object mask of §III-B is not empty): on the study's renders the phase cues do not tell the held object's
pixels from the window's other pixels (pixel AUC 0.56-0.62 on three validation recordings: the object is
displaced 1.5-2 px from the hand's displacement between frames, and its centre lies about one half window
from the hand), so the per-frame masks are noise (frame AUC 0.50-0.55) and no period survives the filter.
A hand that holds a cup, a pitcher or binoculars looks unlike an empty one, and the front end's labels
show the object's extent beside it: the HOG of a window twice the object window's half size and the
labels' fractions on a grid over it (`features.hand_window_features`) separated held from empty frames of
three validation recordings (frame AUC 0.89-0.94, trained on the clips of two other persons; the HOG
alone 0.84-0.92), and §III-D's filter then found all 15 true periods (4 spurious ones beside them).

The clips hold the object for most of their frames, the long recordings for about half: the decision is
taken at equal priors (the training set's log odds subtracted from the logit). The per-frame log odds
then go through a two-state Viterbi path with a cost per switch (`in_hand_path`), before §III-D's filter.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

import crf_jax
from lfd_common import as_array, check_real

# The cost of a switch between "empty" and "held" in `in_hand_path`, nats per frame per second (6.4 at 10
# fps, 16 at 25): chosen on validation recordings at both rates (quick preset seeds 1-3: 15 of 15 events,
# no spurious one against 4 without; paper preset seed 1: 2 spurious against 7); 0.2 and 0.4 left 2 spurious
# at 10 fps, and a fixed cost cannot serve both rates (5 nats lost events at 10 fps, 10 left 3 spurious at 25).
SWITCH_COST_PER_FPS = 0.64
EVIDENCE_CAP = 8.0  # nats: one frame's log odds, however confident, cannot by itself pay for two switches


class InHandClassifier(NamedTuple):
    """A logistic regression of "object in hand" on `features.hand_window_features`.

    Attributes:
        model: the `crf_jax.LinearModel` (classes: 0 empty hand, 1 object in hand).
        log_prior_odds: log(held / empty) of the training frames, subtracted from the logit.
    """

    model: crf_jax.LinearModel
    log_prior_odds: float


def fit_in_hand(features: np.ndarray, held: np.ndarray, l2: float = 1.0) -> InHandClassifier:
    """Fit the classifier (`crf_jax.fit_linear`, logistic) to training frames' features (N, D) and their
    truth held (N,) bool. ValueError (naming the argument) unless both classes occur."""
    y = as_array(held, "held", ndim=1, dtype=bool)
    if y.all() or not y.any():
        raise ValueError(f"held: the training frames need both classes, got {int(y.sum())} held of {y.size}")
    fitted = crf_jax.fit_linear(as_array(features, "features", shape=(y.size, None)), y.astype(np.int32),
                                l2=check_real(l2, "l2", min_value=0.0))
    return InHandClassifier(fitted.model, float(np.log(y.mean() / (1.0 - y.mean()))))


def in_hand_log_odds(classifier: InHandClassifier, features: np.ndarray) -> np.ndarray:
    """(T,) log P(held) / P(empty) of frames' features (T, D) at equal priors."""
    log_p = np.asarray(crf_jax.linear_log_proba(classifier.model, features), np.float64)
    return log_p[:, 1] - log_p[:, 0] - classifier.log_prior_odds


@jax.jit
def _best_path(log_odds, cost):
    def forward(score, evidence):
        switch = score[::-1] - cost
        return jnp.maximum(score, switch) + jnp.stack([-evidence, evidence]) / 2, switch > score

    final, from_other = jax.lax.scan(forward, jnp.zeros(2, log_odds.dtype), log_odds)

    def backward(state, switched):
        return jnp.where(switched[state], 1 - state, state), state

    return jax.lax.scan(backward, jnp.argmax(final), from_other, reverse=True)[1]


def in_hand_path(log_odds: np.ndarray, switch_cost: float) -> np.ndarray:
    """(T,) bool: the "held" / "empty" sequence that maximises sum_t (s_t - 1/2) log_odds_t - switch_cost x
    (number of switches), s_t in {0, 1} (a two-state Viterbi path, `jax.lax.scan`): per-frame decisions
    that flicker (a held object seen from an angle no clip shows) no longer split a period into pieces
    before LfD §III-D's filter. log_odds (T,) finite (0 where a frame cannot decide); switch_cost >= 0 nats.
    ValueError (naming the argument) otherwise."""
    evidence = as_array(log_odds, "log_odds", ndim=1, dtype=np.float32)
    cost = check_real(switch_cost, "switch_cost", min_value=0.0)
    return np.asarray(_best_path(jnp.asarray(evidence), jnp.float32(cost))).astype(bool)
