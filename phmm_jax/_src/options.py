"""Options objects: how to fit a model (`FitOptions`) and how to recognise movements online
(`OnlineOptions`), as opposed to what the model is (`HMMConfig`).

`FitOptions` is passed as `options=` to `fit_hmm`, `fit_hmm_gradient` and `fit_phmm` and never stored
in a model, so a saved model carries no training settings and two fits that differ only in their
options give models of the same static structure. Inside jitted code the real-valued options are
traced arguments (changing `tol` or `reg_covar` does not recompile); only the number of gradient
steps (the length of a `lax.scan`) and the optimiser (a function) are static.

`OnlineOptions` is passed as `options=` to `online_recognizer`; the recogniser keeps it (with
`max_frames` resolved) as static metadata, since the window and the buffer fix array shapes.
"""
from __future__ import annotations

import dataclasses
from typing import Any

import optax

from lfd_common import check_int, check_real

# One instance, so that every default `FitOptions()` holds the same (hashable) optimiser and the
# jitted gradient fit is traced once for it.
DEFAULT_OPTIMIZER: optax.GradientTransformation = optax.lbfgs()


@dataclasses.dataclass(frozen=True)
class FitOptions:
    """Options of the fitting functions (defaults: those the experiments of the papers use).

    Passed as `options=` to `fit_hmm`, `fit_hmm_gradient` and `fit_phmm`; never stored in a model.
    Every field is validated when the object is built.

    Attributes:
        max_iter: EM iterations at most (`fit_hmm`; the global EM of `fit_phmm`), >= 0.
        tol: EM stops once the mean log-likelihood per frame improves by less than `tol` (nats).
        reg_covar: Added to every covariance diagonal (a floor, in squared data units), by EM and
            by the gradient fit's parametrisation alike. 0 (pure maximum likelihood) is accepted,
            but a fit that then leaves a covariance singular (a constant feature, collinear
            features, a state of at most D frames) raises `ValueError` naming `reg_covar` rather
            than return a NaN model.
        duration_pseudocount: Dirichlet pseudo-count added to every *allowed* continue/exit count
            in the M step, so that a duration unseen in training stays possible (0: pure maximum
            likelihood).
        freeze_means_after: `fit_hmm` keeps the means fixed after this many iterations (None:
            never; 1 is the synchronised local training of PHMM §III-B1, eq. 2).
        local_max_iter: EM iterations at most for the local models of `fit_phmm` (None: `max_iter`).
        gradient_steps: Optimiser steps of `fit_hmm_gradient`.
        optimizer: The `optax.GradientTransformation` of `fit_hmm_gradient` (default
            `optax.lbfgs()`, whose line search evaluates the objective itself; any optax optimiser
            works).

    Raises:
        ValueError: Naming the field, for a value of the wrong type or outside its range.
    """

    max_iter: int = 50
    tol: float = 1e-4
    reg_covar: float = 1e-4
    duration_pseudocount: float = 1e-3
    freeze_means_after: int | None = None
    local_max_iter: int | None = None
    gradient_steps: int = 200
    optimizer: optax.GradientTransformation = DEFAULT_OPTIMIZER

    def __post_init__(self):
        check_int(self.max_iter, "max_iter", min_value=0)
        check_real(self.tol, "tol", min_value=0.0)
        check_real(self.reg_covar, "reg_covar", min_value=0.0)
        check_real(self.duration_pseudocount, "duration_pseudocount", min_value=0.0)
        if self.freeze_means_after is not None:
            check_int(self.freeze_means_after, "freeze_means_after", min_value=0)
        if self.local_max_iter is not None:
            check_int(self.local_max_iter, "local_max_iter", min_value=0)
        check_int(self.gradient_steps, "gradient_steps", min_value=0)
        if not isinstance(self.optimizer, optax.GradientTransformation):
            raise ValueError(
                f"optimizer: expected an optax.GradientTransformation, got {type(self.optimizer).__name__}")

    def replace(self, **changes: Any) -> "FitOptions":
        """A copy with `changes` applied (validated again).

        Args:
            **changes: Field names and their new values.

        Returns:
            The new `FitOptions`.
        """
        return dataclasses.replace(self, **changes)


def check_options(options) -> FitOptions:
    """`options` if it is a `FitOptions`, else `ValueError` naming the argument."""
    if not isinstance(options, FitOptions):
        raise ValueError(f"options: expected a phmm_jax.FitOptions, got {type(options).__name__}")
    return options


@dataclasses.dataclass(frozen=True)
class OnlineOptions:
    """Settings of the online recogniser (BMVC 2008 §5.4; Humanoids 2008 §V), defaults as used there.

    Passed as `options=` to `online_recognizer`; the displacement `threshold`, which depends on the
    data's units and the tracker's noise, stays an argument of its own. Every field is validated
    when the object is built.

    Attributes:
        window: W >= 1, the detector's look-ahead in frames, and so the latency of a report.
        exit_threshold: In (0, 1]. A movement may also end where the models' exit probability (the
            final state's exit, BMVC §5.4) reaches it, although the hand is not back at rest.
        lattice_points: >= 1. Every class keeps a forward state for each of the lattice_points^d
            candidates φ of the lattice that `recognize` starts from.
        max_frames: F, the longest movement kept, >= 1 (and at least the shortest path of any
            class, checked by `online_recognizer`). None: the longest path of any class (then
            every class needs explicit durations, whose paths are bounded).
        epsilon: >= 0, passed to `recognize` for the refinement of a finished movement.
        n_steps: >= 1, passed to `recognize` for the refinement.
        face_steps: >= 0, passed to `recognize` for the refinement.

    Raises:
        ValueError: Naming the field, for a value of the wrong type or outside its range.
    """

    window: int = 5
    exit_threshold: float = 0.5
    lattice_points: int = 5
    max_frames: int | None = None
    epsilon: float = 0.1
    n_steps: int = 6
    face_steps: int = 3

    def __post_init__(self):
        checked = dict(
            window=check_int(self.window, "window", min_value=1),
            exit_threshold=check_real(self.exit_threshold, "exit_threshold", min_value=0.0, exclusive_min=True,
                                      max_value=1.0),
            lattice_points=check_int(self.lattice_points, "lattice_points", min_value=1),
            epsilon=check_real(self.epsilon, "epsilon", min_value=0.0),
            n_steps=check_int(self.n_steps, "n_steps", min_value=1),
            face_steps=check_int(self.face_steps, "face_steps", min_value=0),
        )
        if self.max_frames is not None:
            checked["max_frames"] = check_int(self.max_frames, "max_frames", min_value=1)
        for name, value in checked.items():  # plain ints and floats, so equal options hash alike
            object.__setattr__(self, name, value)

    def replace(self, **changes: Any) -> "OnlineOptions":
        """A copy with `changes` applied (validated again).

        Args:
            **changes: Field names and their new values.

        Returns:
            The new `OnlineOptions`.
        """
        return dataclasses.replace(self, **changes)


def check_online_options(options) -> OnlineOptions:
    """`options` if it is an `OnlineOptions`, else `ValueError` naming the argument."""
    if not isinstance(options, OnlineOptions):
        raise ValueError(f"options: expected a phmm_jax.OnlineOptions, got {type(options).__name__}")
    return options
