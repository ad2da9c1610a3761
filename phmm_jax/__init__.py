"""phmm_jax: explicit-duration left-right HMMs and parametric HMMs (PHMMs) in JAX.

Recognition and synthesis of parametric movements after Herzog, Ude, Krüger (Humanoids 2008) and
Herzog, Krüger, Grest (BMVC 2008). Shapes: B sequences, T frames, D features, N states, P
pseudo-states per state, K classes, d parameters. Sequences are a padded (B, T, D) array with
lengths (B,), one (T, D) sequence, or a list of (T_b, D) arrays. A model is a static structure
(`HMMConfig`) plus a parameters pytree; how it is fitted (`FitOptions`) is never part of it.

- Models: `HMMConfig`, `HMM`, `PHMM`, `expand_to_dense`.
- Inference: `log_likelihood`, `posteriors`, `messages`, `viterbi` (batch entry points take `mesh=`).
- Training: `fit_hmm` (Baum–Welch EM), `fit_hmm_gradient` (optax), `fit_phmm` (synchronised local
  training), all with `options=FitOptions(...)`.
- Parametric HMMs: `phmm_log_likelihood`, `recognize`, `synthesize`, `target_to_phi`,
  `with_observation_noise`, `estimate_noise_variance`.
- Streaming and online recognition: `init_stream`, `stream_step`, `stream_forward`;
  `online_recognizer(phmms, threshold, options=OnlineOptions(...))`, `online_step`, `online_scan`,
  `run_online`, `OnlineStream`.
- Retargeting to a robot arm: `retarget`, `solve_arm`. Persistence: `save`, `load`.

Every public function raises `ValueError` whose message starts with the argument's name for a
wrong type, shape or value, and fits never return NaN.

Example:
    ```python
    import phmm_jax as P

    config = P.HMMConfig(n_states=20, min_duration=4, max_duration=6)
    phmm = P.fit_phmm(groups, grid_shape=(2, 2), config=config,   # groups: one list per grid corner
                      options=P.FitOptions(max_iter=30))
    result = P.recognize([pointing, phmm], X, lengths)             # label (B,), phi (B, 2, 2)
    movement = P.synthesize(phmm, [0.5, 0.25], length=100)         # (100, D)
    P.save("reaching.npz", phmm)
    ```
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
from phmm_jax._src.options import FitOptions, OnlineOptions
from phmm_jax._src.parametric import (search_parameters, PHMM, Recognition, batch_phmm_log_likelihood, fit_phmm, grid_points,
                                      interpolate, phmm_log_likelihood, recognize)
from phmm_jax._src.retarget import (ArmAngles, ArmSolution, DEFAULT_BASE_FRAME, MARKER_ORDER, retarget,
                                    solve_arm)
from phmm_jax._src.stream import StreamState, init_stream, stream_forward, stream_step, stream_step_batch
from phmm_jax._src.synthesis import hermite_spline, multilinear_map, synthesize, target_to_phi

__all__ = [
    "online_step_batch_jit", "online_step_jit", "search_parameters",
    "ArmAngles", "ArmSolution", "DEFAULT_BASE_FRAME", "DenseHMM", "FitOptions", "HMM", "HMMConfig", "MARKER_ORDER",
    "Messages", "OnlineEvents", "OnlineOptions", "OnlineFrame", "OnlineRecognizer", "OnlineState", "OnlineStream", "PHMM", "PHMMStructure",
    "Posteriors", "Recognition", "StreamState", "batch_log_likelihood", "batch_phmm_log_likelihood", "batch_posteriors", "em_step", "estimate_noise_variance",
    "expand_to_dense", "expected_durations", "fit_hmm", "fit_hmm_gradient", "fit_phmm", "gaussian_log_density", "gaussian_log_density_columns", "grid_points",
    "hermite_spline", "init_online", "init_stream", "interpolate", "load", "log_likelihood", "messages", "multilinear_map",
    "online_recognizer", "online_scan", "online_step", "online_step_batch", "phmm_log_likelihood", "posteriors", "recognize", "retarget",
    "run_online", "save", "solve_arm", "stacked_log_density_columns", "stream_forward", "stream_step", "stream_step_batch", "synthesize",
    "target_to_phi", "transitions_from_durations", "viterbi", "with_observation_noise",
]
