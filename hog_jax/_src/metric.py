"""A learned linear metric on HOG features: whitened linear discriminant analysis.

Shapes: N points, D feature dimension, M classes, D' output dimension.

The within-class scatter S_w (the pooled covariance of the points about their class means) is shrunk
towards its mean eigenvalue, S = (1 - λ) S_w + λ (tr S_w / D) I (Ledoit-Wolf style shrinkage keeps it
invertible when D approaches N or features are constant), and the data are whitened by S^-1/2: in the
whitened space Euclidean distance is the Mahalanobis distance of S, so directions in which views of
one grasp differ (viewpoint, posture, hand shape) count less than directions that separate grasps.
The whitened class means' scatter gives the discriminant directions (eigenvectors, largest first);
`n_components` keeps the first D' of them (None: all D, a rotation of the whitened space that leaves
its distances unchanged). The metric is x -> (x - mean) @ matrix; kNN and LSH use it alike by indexing
the transformed database. Fitted in float64 NumPy (D is small), applied in JAX.
"""
from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from lfd_common import as_array, check_int, check_real

__all__ = ["LinearMetric", "apply_metric", "fit_metric"]


class LinearMetric(NamedTuple):
    """A learned linear map of features, x -> (x - mean) @ matrix (`fit_metric`).

    Attributes:
        mean: (D,) the feature mean.
        matrix: (D, D') the whitening and discriminant directions.
    """

    mean: Float[Array, " D"]
    matrix: Float[Array, "D Dp"]


def fit_metric(x: Float[ArrayLike, "N D"], labels: Int[ArrayLike, " N"], shrinkage: float = 0.1,
               n_components: int | None = None) -> LinearMetric:
    """A learned metric on features: whitened linear discriminant analysis.

    The within-class scatter S_w is shrunk towards its mean eigenvalue,
    S = (1 - λ) S_w + λ (tr S_w / D) I (Ledoit-Wolf style: invertible when D approaches N or features
    are constant), and the data are whitened by S^-1/2, so that directions in which views of one
    grasp differ count less than directions that separate grasps (GRASP §V's distance, learnt). The
    whitened class means' scatter gives the discriminant directions, largest first. Fitted in float64
    NumPy, applied in JAX; index and query the transformed features alike.

    Args:
        x: (N, D) features, N >= 2.
        labels: (N,) integer classes, at least two distinct.
        shrinkage: λ in [0, 1].
        n_components: D', the discriminant directions kept, in [1, D]; None: all D (a rotation of the
            whitened space that leaves its distances unchanged).

    Returns:
        A `LinearMetric`.

    Raises:
        ValueError: naming the argument for non-finite x or fewer than 2 points, labels of another
            length or with fewer than two classes, λ or n_components out of range, or (with λ = 0) a
            singular within-class scatter (`shrinkage`).
    """
    x = as_array(x, "x", ndim=2, dtype=np.float64)
    if x.shape[0] < 2:
        raise ValueError(f"x: need at least 2 points, got {x.shape[0]}")
    y = as_array(labels, "labels", shape=(x.shape[0],), dtype=np.int64)
    classes = np.unique(y)
    if classes.size < 2:
        raise ValueError("labels: need at least two classes")
    lam = check_real(shrinkage, "shrinkage", min_value=0.0, max_value=1.0)
    D = x.shape[1]
    n_out = D if n_components is None else check_int(n_components, "n_components", min_value=1, max_value=D)
    index = np.searchsorted(classes, y)
    means = np.stack([x[index == c].mean(0) for c in range(classes.size)])  # (M, D): one row per class
    centred = x - means[index]
    s_w = centred.T @ centred / x.shape[0]
    s = (1.0 - lam) * s_w + lam * (np.trace(s_w) / D) * np.eye(D)
    w_eig, v = np.linalg.eigh(s)
    if w_eig.min() <= 1e-12 * max(w_eig.max(), 1e-300):
        raise ValueError("shrinkage: the within-class scatter is singular; use shrinkage > 0")
    whiten = v @ np.diag(w_eig ** -0.5) @ v.T                        # S^-1/2, symmetric
    counts = np.bincount(index, minlength=classes.size)
    centre = x.mean(0)
    wm = (means - centre) @ whiten                                  # whitened class means (M, D)
    s_b = (wm * counts[:, None]).T @ wm / x.shape[0]
    b_eig, u = np.linalg.eigh(s_b)
    u = u[:, np.argsort(b_eig)[::-1][:n_out]]                        # discriminant directions, largest first
    return LinearMetric(jnp.asarray(centre, jnp.float32), jnp.asarray(whiten @ u, jnp.float32))


def apply_metric(metric: LinearMetric, x: Float[ArrayLike, "N D"]) -> Float[Array, "N Dp"]:
    """Features in a learned metric: (x - mean) @ matrix.

    Args:
        metric: the `LinearMetric` (`fit_metric`).
        x: (N, D) features.

    Returns:
        (N, D') transformed features.

    Raises:
        ValueError: `x` of a wrong shape or with non-finite values.
    """
    x = as_array(x, "x", shape=(None, metric.mean.shape[0]), dtype=np.float32)
    return (jnp.asarray(x) - metric.mean) @ metric.matrix
