"""How to fit a model, as opposed to what the model is (`model.HMMConfig`): the options of every `fit_*`.

`FitOptions` is passed as `options=` to `fit_hmm`, `fit_hmm_gradient` and `fit_phmm` and never stored
in a model, so a saved model carries no training settings and two fits that differ only in their
options give models of the same static structure. Inside jitted code the real-valued options are
traced arguments (changing `tol` or `reg_covar` does not recompile); only the number of gradient
steps (the length of a `lax.scan`) and the optimiser (a function) are static.
"""
from __future__ import annotations

import dataclasses

import optax

from lfd_common import check_int, check_real

# One instance, so that every default `FitOptions()` holds the same (hashable) optimiser and the
# jitted gradient fit is traced once for it.
DEFAULT_OPTIMIZER: optax.GradientTransformation = optax.lbfgs()


@dataclasses.dataclass(frozen=True)
class FitOptions:
    """Options of the fitting functions (defaults: those the experiments of the papers use).

    max_iter: EM iterations at most (`fit_hmm`; the global EM of `fit_phmm`).
    tol: EM stops once the mean log-likelihood per frame improves by less than `tol` (nats).
    reg_covar: added to every covariance diagonal (a floor, in squared data units), by EM and by the
        gradient fit's parametrisation alike. 0 (pure maximum likelihood) is accepted, but a fit
        that then leaves a covariance singular (a constant feature, collinear features, a state of
        at most D frames) raises `ValueError` naming `reg_covar` rather than return a NaN model.
    duration_pseudocount: Dirichlet pseudo-count added to every *allowed* continue/exit count in the
        M step, so that a duration unseen in training stays possible (0: pure maximum likelihood).
    freeze_means_after: `fit_hmm` keeps the means fixed after this many iterations (None: never;
        1 is the synchronised local training of PHMM §III-B1, eq. 2).
    local_max_iter: EM iterations at most for the local models of `fit_phmm` (None: `max_iter`).
    gradient_steps: optimiser steps of `fit_hmm_gradient`.
    optimizer: the `optax.GradientTransformation` of `fit_hmm_gradient` (default `optax.lbfgs()`,
        whose line search evaluates the objective itself; any optax optimiser works).
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

    def replace(self, **changes) -> "FitOptions":
        return dataclasses.replace(self, **changes)


def check_options(options) -> FitOptions:
    """`options` if it is a `FitOptions`, else `ValueError` naming the argument."""
    if not isinstance(options, FitOptions):
        raise ValueError(f"options: expected a phmm_jax.FitOptions, got {type(options).__name__}")
    return options
