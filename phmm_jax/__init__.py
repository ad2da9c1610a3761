"""phmm_jax: explicit-duration left-right HMMs and parametric HMMs in JAX.

Shapes: B sequences, T frames, D features, N states, P pseudo-states per state, d parameters.

A model is a static structure plus a parameters pytree; how it is fitted (FitOptions) is an argument
of the fit, never part of the model.

Models
    HMMConfig(n_states, min_duration, max_duration, covariance_type)   the static structure
    HMM            means (N, D), covariances (N, D, D), log_cont / log_exit (N, P), config
    PHMM           local HMMs stacked over the C grid corners, grid_shape (g_1, ..., g_d)
    expand_to_dense(hmm) -> DenseHMM   the equivalent ordinary HMM over N·P pseudo-states

Inference (X: (B, T, D) with lengths (B,), a (T, D) sequence, or a list of (T_b, D) arrays; every batch
entry point below, fit_hmm and recognize included, takes mesh=: a jax.sharding.Mesh to split the batch over,
see lfd_common.sharding)
    log_likelihood(hmm, X, lengths)  -> (B,)
    posteriors(hmm, X, lengths)      -> Posteriors(state (B, T, N), pseudo (B, T, N, P), loglik (B,))
    messages(hmm, X, lengths)        -> Messages(log_alpha, log_beta (B, T, N, P), loglik (B,))
    viterbi(hmm, X, lengths)         -> (states (B, T), log-probability (B,))

Training (options: FitOptions(max_iter, tol, reg_covar, duration_pseudocount, freeze_means_after,
          local_max_iter, gradient_steps, optimizer))
    fit_hmm(X, lengths, config, init=None, *, options)             Baum–Welch EM
    fit_hmm_gradient(X, lengths, config, init=None, *, options)    optax (default L-BFGS) on the NLL
    fit_phmm(groups, grid_shape, config, *, options)               synchronised local training

Parametric HMMs
    phmm_log_likelihood(phmm, X, phi, lengths) -> (B,), differentiable in phi
    recognize(phmms, X, lengths, epsilon=0.1, n_steps=6, lattice_points=None, face_steps=3) -> Recognition(label (B,), phi (B, K, d), loglik (B, K))
    synthesize(phmm, phi, length=100)          -> (length, D) mean movement
    with_observation_noise(model, variance)    -> the HMM / PHMM of x = y + N(0, variance I): Σ + variance I
    estimate_noise_variance(X, lengths)        -> σ² of white noise, from the sequences' second differences
    target_to_phi(corner_targets, targets)     -> (M, d) interpolation parameters of target points

Online recognition (BMVC 2008 §5.4, Humanoids 2008 §V; frames arrive one at a time: `phmm_jax.stream`, `.online`)
    init_stream(hmm, n_streams=None) -> StreamState(log_alpha (N, P), n_frames, log_prefix, loglik)
    stream_step(hmm, state, x_t (D,)) / stream_step_batch(hmm, states, X_t (S, D))   one frame, pure, jit-able
    stream_forward(hmm, X (T, D), state=None) -> StreamState (T, ...)   by lax.scan; equals the batch
        forward pass at every prefix (loglik: the sequence ends here, = log_likelihood of the prefix)
    online_recognizer(phmms, threshold, window=5, exit_threshold=0.5, lattice_points=5, max_frames=None)
        -> OnlineRecognizer: per class a forward state for each φ of the start lattice (fixed cost per frame)
    init_online(recognizer, n_streams=None) -> OnlineState
    online_step(recognizer, state, x_t) / online_step_batch -> (OnlineState, OnlineFrame)   pure, jit-able
    online_scan(recognizer, stream (T, D)) -> (OnlineState, OnlineFrame (T, ...))   by lax.scan
    run_online(recognizer, stream (T, D)) -> OnlineEvents(found, start, end, report, label, phi (E, d), loglik (E, K))
    OnlineStream(recognizer).push(x_t) -> OnlineEvents   a live stream; report = end + window frames

Retargeting to a robot arm (Humanoids 2008 §IV-B, eqs. 10-24)
    retarget(markers (..., T, 7, 3), upper_arm, forearm) -> ArmAngles (shoulder Cardan angles, elbow, wrist twist)
    solve_arm(q, r, o, upper_arm, forearm) -> ArmSolution  the same for elbow/hand/finger vectors; MARKER_ORDER: marker layout

Persistence
    save(path, model), load(path)   structure as JSON + arrays, checked against each other on load

Errors and edge cases
    Every public function raises `ValueError` whose message starts with the argument's name for a
    wrong type, shape or value (NaN/inf, lengths no path fits, n_steps < 1, face_steps < 0, an
    empty or non-tuple grid_shape) and for finite values that would overflow the compute dtype
    inside (data ~1e20 from the means in float32, φ = 1e30, epsilon = 1e30). Fits never return NaN:
    `reg_covar` floors every variance (default 1e-4); with reg_covar=0 a singular covariance raises
    naming `reg_covar`; a state without responsibility keeps its Gaussian (RuntimeWarning).
"""
from phmm_jax._src.api import (Messages, Posteriors, batch_log_likelihood, batch_posteriors, log_likelihood,
                               messages, posteriors, viterbi)
from phmm_jax._src.em import em_step, fit_hmm
from phmm_jax._src.emissions import (gaussian_log_density, gaussian_log_density_columns,
                                     stacked_log_density_columns)
from phmm_jax._src.gradfit import fit_hmm_gradient
from phmm_jax._src.io import PHMMStructure, load, save
from phmm_jax._src.model import (DenseHMM, HMM, HMMConfig, expand_to_dense, expected_durations,
                                 transitions_from_durations)
from phmm_jax._src.noise import estimate_noise_variance, with_observation_noise
from phmm_jax._src.online import (online_step_batch_jit, online_step_jit, OnlineFrame, OnlineRecognizer, OnlineState, init_online, online_recognizer,
                                  online_scan, online_step, online_step_batch)
from phmm_jax._src.online_events import OnlineEvents, OnlineStream, run_online
from phmm_jax._src.options import FitOptions
from phmm_jax._src.parametric import (search_parameters, PHMM, Recognition, batch_phmm_log_likelihood, fit_phmm, grid_points,
                                      interpolate, phmm_log_likelihood, recognize)
from phmm_jax._src.retarget import (ArmAngles, ArmSolution, DEFAULT_BASE_FRAME, MARKER_ORDER, retarget,
                                    solve_arm)
from phmm_jax._src.stream import StreamState, init_stream, stream_forward, stream_step, stream_step_batch
from phmm_jax._src.synthesis import hermite_spline, multilinear_map, synthesize, target_to_phi

__all__ = [
    "online_step_batch_jit", "online_step_jit", "search_parameters",
    "ArmAngles", "ArmSolution", "DEFAULT_BASE_FRAME", "DenseHMM", "FitOptions", "HMM", "HMMConfig", "MARKER_ORDER",
    "Messages", "OnlineEvents", "OnlineFrame", "OnlineRecognizer", "OnlineState", "OnlineStream", "PHMM", "PHMMStructure",
    "Posteriors", "Recognition", "StreamState", "batch_log_likelihood", "batch_phmm_log_likelihood", "batch_posteriors", "em_step", "estimate_noise_variance",
    "expand_to_dense", "expected_durations", "fit_hmm", "fit_hmm_gradient", "fit_phmm", "gaussian_log_density", "gaussian_log_density_columns", "grid_points",
    "hermite_spline", "init_online", "init_stream", "interpolate", "load", "log_likelihood", "messages", "multilinear_map",
    "online_recognizer", "online_scan", "online_step", "online_step_batch", "phmm_log_likelihood", "posteriors", "recognize", "retarget",
    "run_online", "save", "solve_arm", "stacked_log_density_columns", "stream_forward", "stream_step", "stream_step_batch", "synthesize",
    "target_to_phi", "transitions_from_durations", "viterbi", "with_observation_noise",
]
