"""Reach onset and contact found online in the whole recording, against the annotations.

Both detectors read the causal features of `data.event_features` (wrist displacement from the first
frame, wrist speed, grip aperture, in shoulder widths) frame by frame, and are fitted on the
training persons only:

* `speed`: the wrist's displacement over the last w frames divided by w (w from `speed_windows`);
  onset where it first exceeds
  a threshold, contact where it first falls below a share of its peak so far after the onset. Each
  estimate is the crossing frame minus the median delay of that crossing on the training movements;
  window and thresholds are those with the lowest median |error| on the training movements. Latency: the
  crossing frame minus the true event.
* `hmm`: a left-right HMM rest → reach (`reach_states`) → after contact (`after_states`) with
  diagonal Gaussians and self-loops set from the annotated segments of the training movements
  (the reach and the first `after_frames` frames after contact cut into equal parts in time), run
  forward over the stream; with a fixed lag ℓ, the state posterior of frame t given frames up to
  t + ℓ. Onset: the first frame whose posterior of "reach or later" exceeds ½; contact: the first
  whose posterior of "after contact" does. Latency: the estimate + ℓ minus the true event.
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np
from scipy.special import logsumexp


class Events(NamedTuple):
    """Per movement: estimated onset and contact frames, the frames at which each was known."""

    onset: np.ndarray
    contact: np.ndarray
    onset_known: np.ndarray
    contact_known: np.ndarray


def _smoothed_speed(F: np.ndarray, window: int) -> np.ndarray:
    """|wrist(t) − wrist(t − window)| / window (0 for the first frames): causal, and the keypoints'
    frame-to-frame jitter shrinks with the window instead of adding up as in a mean of speeds."""
    wrist = F[:, :2]
    out = np.zeros(len(F))
    out[window:] = np.linalg.norm(wrist[window:] - wrist[:-window], axis=-1) / window
    return out


def _speed_crossings(F: np.ndarray, window: int, on: float, stop: float) -> tuple[int, int]:
    s = _smoothed_speed(F, window)
    above = np.nonzero(s[window:] > on)[0]
    onset = window + int(above[0]) if len(above) else len(s) - 1
    # below the share of the running peak; no further condition on how high the peak rose: slow
    # persons peak at only 1.3-2x the onset threshold
    peak = np.maximum.accumulate(s[onset:])
    below = np.nonzero(s[onset:] < stop * peak)[0]
    contact = onset + int(below[0]) if len(below) else len(s) - 1
    return onset, contact


def fit_speed(feats: list[np.ndarray], onsets: np.ndarray, contacts: np.ndarray, cfg
              ) -> tuple[int, float, float, int, int]:
    """(window, onset threshold, stop share, onset delay, contact delay) of the lowest median |error| (onset
    and contact errors added) on the given (training) movements."""
    best, best_cost = None, np.inf
    for window, on, stop in itertools.product(cfg.speed_windows, cfg.speed_onsets, cfg.speed_stops):
        cross = np.array([_speed_crossings(F, window, on, stop) for F in feats])
        d_on, d_off = np.median(cross[:, 0] - onsets), np.median(cross[:, 1] - contacts)
        cost = (np.median(np.abs(cross[:, 0] - onsets - np.round(d_on)))
                + np.median(np.abs(cross[:, 1] - contacts - np.round(d_off))))
        if cost < best_cost:
            best, best_cost = (window, on, stop, int(np.round(d_on)), int(np.round(d_off))), cost
    return best


def detect_speed(params, feats: list[np.ndarray], cfg) -> Events:
    window, on, stop, d_on, d_off = params
    cross = np.array([_speed_crossings(F, window, on, stop) for F in feats])
    return Events(cross[:, 0] - d_on, cross[:, 1] - d_off, cross[:, 0], cross[:, 1])


class EventHMM(NamedTuple):
    """means, variances (S, D); log transition matrix (S, S); index of the first reach state and of the
    first after-contact state."""

    means: np.ndarray
    variances: np.ndarray
    log_trans: np.ndarray
    first_reach: int
    first_after: int


def fit_event_hmm(feats: list[np.ndarray], onsets: np.ndarray, contacts: np.ndarray, cfg) -> EventHMM:
    """The supervised left-right event HMM of the module docstring from the training movements."""
    n_r, n_a = cfg.reach_states, cfg.after_states
    n = 1 + n_r + n_a
    frames, durations = [[] for _ in range(n)], [[] for _ in range(n)]
    for F, on, c in zip(feats, onsets, contacts):
        parts = [F[:on]]
        reach = F[on:c + 1]
        parts += [reach[(np.arange(len(reach)) * n_r // len(reach)) == k] for k in range(n_r)]
        after = F[c + 1:c + 1 + cfg.after_frames]
        if len(after) >= n_a:
            parts += [after[(np.arange(len(after)) * n_a // len(after)) == k] for k in range(n_a)]
        for k, part in enumerate(parts):
            if len(part):
                frames[k].append(part)
                durations[k].append(len(part))
    stacked = [np.concatenate(f) for f in frames]
    means = np.stack([f.mean(0) for f in stacked])
    variances = np.stack([f.var(0) for f in stacked]) + 1e-6
    log_trans = np.full((n, n), -np.inf)
    for k in range(n):
        stay = 1.0 - 1.0 / max(np.mean(durations[k]), 1.0 + 1e-3) if k < n - 1 else 1.0
        log_trans[k, k] = np.log(stay)
        if k < n - 1:
            log_trans[k, k + 1] = np.log1p(-stay)
    return EventHMM(means, variances, log_trans, 1, 1 + n_r)


def _log_emissions(model: EventHMM, F: np.ndarray) -> np.ndarray:
    d = (F[..., None, :] - model.means) ** 2 / model.variances
    return -0.5 * (d.sum(-1) + np.log(2 * np.pi * model.variances).sum(-1))


def _forward(model: EventHMM, log_b: np.ndarray) -> np.ndarray:
    """Normalised log filtering distributions log p(s_t | x_{0:t}) (B, T, S) of padded streams
    (B, T, S), one (S, S) step per frame by `lax.scan`, as it would run live."""
    import jax
    import jax.numpy as jnp
    from jax.scipy.special import logsumexp as jlogsumexp

    log_trans = jnp.asarray(model.log_trans)
    start = jnp.full(log_b.shape[2], -jnp.inf).at[0].set(0.0)

    def step(prev, lb):
        a = jlogsumexp(prev[:, :, None] + log_trans[None], axis=1) + lb
        a = a - jlogsumexp(a, axis=1, keepdims=True)
        return a, a

    first = start[None] + log_b[:, 0]
    first = first - jlogsumexp(first, axis=1, keepdims=True)
    _, rest = jax.lax.scan(step, first, jnp.swapaxes(jnp.asarray(log_b[:, 1:]), 0, 1))
    return np.concatenate([np.asarray(first)[:, None], np.swapaxes(np.asarray(rest), 0, 1)], axis=1)


def _lagged_backward(model: EventHMM, log_b: np.ndarray, lag: int) -> np.ndarray:
    """log p(x_{t+1:t+lag} | s_t) (B, T, S), every t at once (frames past the end count as unobserved)."""
    B, T, S = log_b.shape
    padded = np.concatenate([log_b, np.zeros((B, lag, S))], axis=1)
    beta = np.zeros((B, T, S))
    for k in range(lag, 0, -1):  # the lag's steps, all frames together
        beta = logsumexp(model.log_trans[None, None] + (padded[:, k:k + T] + beta)[:, :, None, :], axis=3)
    return beta


def detect_hmm(model: EventHMM, feats: list[np.ndarray], lag: int) -> Events:
    """Onset and contact of each movement by the fixed-lag posteriors (module docstring)."""
    lengths = np.array([len(F) for F in feats])
    padded = np.zeros((len(feats), lengths.max(), feats[0].shape[1]))
    for k, F in enumerate(feats):
        padded[k, :len(F)] = F
    log_b = _log_emissions(model, padded)
    # frames past a stream's end count as unobserved
    log_b = np.where(np.arange(lengths.max())[None, :, None] < lengths[:, None, None], log_b, 0.0)
    post = _forward(model, log_b) + _lagged_backward(model, log_b, lag)
    post = np.exp(post - logsumexp(post, axis=2, keepdims=True))
    inside = np.arange(lengths.max())[None] < lengths[:, None]

    def first(mask):
        mask = mask & inside
        return np.where(mask.any(1), np.argmax(mask, axis=1), lengths - 1)

    onset = first(post[:, :, model.first_reach:].sum(2) > 0.5)
    contact = first(post[:, :, model.first_after:].sum(2) > 0.5)
    return Events(onset, contact, onset + lag, contact + lag)
