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
taken at equal priors (the training set's log odds subtracted from the logit).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

import crf_jax
from lfd_common import as_array, check_real

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


def in_hand_probability(classifier: InHandClassifier, features: np.ndarray) -> np.ndarray:
    """(T,) P(object in hand) of frames' features (T, D) at equal priors."""
    log_p = np.asarray(crf_jax.linear_log_proba(classifier.model, features), np.float64)
    return 1.0 / (1.0 + np.exp(-(log_p[:, 1] - log_p[:, 0] - classifier.log_prior_odds)))
