"""Recognition under i.i.d. observation noise: if the tracker reports x_t = y_t + n_t with
n_t ~ N(0, σ² I) independent of the movement y, a state's emission N(μ, Σ) for y becomes N(μ, Σ + σ² I)
for x. Models trained on clean movements and scored on noisy ones are too confident without that term.
`estimate_noise_variance` reads σ² off the sequences themselves, so no setting is tuned on test data."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike

from lfd_common import check_real, pad_sequences
from phmm_jax._src.checks import check_type
from phmm_jax._src.data import Lengths, Sequences
from phmm_jax._src.model import HMM
from phmm_jax._src.parametric import PHMM

# median of chi²(1): for Gaussian z, median(z²) = 0.4549 var(z)
_CHI2_1_MEDIAN = 0.454936


def estimate_noise_variance(X: Sequences, lengths: Lengths = None) -> float:
    """Estimate the variance σ² of white observation noise from the sequences themselves.

    From the second differences d_t = x_t − 2x_{t−1} + x_{t−2} of all valid frames: for white noise
    var(d) = 6σ², and a movement sampled densely enough adds little to d, so
    σ² = median(d²) / (6 · 0.4549) (the median makes outliers and fast phases harmless). No setting
    is tuned on test data. BMVC §5.3 tests recognition under added Gaussian noise.

    Args:
        X: (B, T, D) padded with `lengths`, a (T, D) sequence or a list of (T_b, D) arrays.
        lengths: (B,) frames per sequence, or None (all T, or the list's lengths).

    Returns:
        σ², the same on every feature (data units squared).

    Raises:
        ValueError: Naming the argument: no sequence of at least 3 frames (`X`), NaN/inf within the
            lengths, lengths outside [1, T].
    """
    X, lengths = pad_sequences(X, lengths, dtype=np.float64)
    if X.shape[1] < 3 or np.max(lengths) < 3:
        raise ValueError("X: the noise estimate needs a sequence of at least 3 frames")
    second = X[:, 2:] - 2 * X[:, 1:-1] + X[:, :-2]  # (B, T-2, D)
    valid = np.arange(X.shape[1] - 2)[None, :] < (lengths[:, None] - 2)
    return float(np.median(second[valid] ** 2) / (6 * _CHI2_1_MEDIAN))


def with_observation_noise(model: HMM | PHMM, variance: float | ArrayLike) -> HMM | PHMM:
    """The model of x = y + n, n ~ N(0, variance · I): every state covariance plus variance · I.

    A state's emission N(μ, Σ) for the clean movement y becomes N(μ, Σ + σ² I) for the tracked x
    (for a PHMM: at every grid corner, so every interpolated λ^φ gets it too, PHMM eq. 1).

    Args:
        model: An `HMM` or a `PHMM`.
        variance: σ², a finite number >= 0 (e.g. from `estimate_noise_variance`).

    Returns:
        The model of the same type with the widened covariances.

    Raises:
        ValueError: Naming `variance` (negative, NaN/inf, not a number) or `model` (neither an
            HMM nor a PHMM).
    """
    variance = check_real(variance, "variance", min_value=0.0)
    if isinstance(model, PHMM):
        return PHMM(with_observation_noise(model.local, variance), model.grid_shape)
    check_type(model, "model", HMM, "a phmm_jax.HMM or PHMM")
    eye = jnp.eye(model.means.shape[-1], dtype=model.covariances.dtype)
    return model.replace(covariances=model.covariances + jnp.asarray(variance, model.covariances.dtype) * eye)
