"""HMM inference throughput: phmm_jax against dynamax and hmmlearn on the PHMM papers' workload.

    python -m experiments.bench.bench_hmm --preset paper --out runs/bench_hmm

Workload (paper preset): B = 280 movements of T = 100 frames, D = 21 (7 markers x 3-D), an HMM of
N = 20 states with durations 4-6 (120 pseudo-states), full covariances, fitted by our EM on simulated
reaching movements. Every side scores the same model (`expand_to_dense` of ours for the anchors) on
the same sequences, timed from the (B, T, D) frames to the result, median of repeats after warm-up
(ours and the dynamax filter / smoother round-robin, one call of each per repeat):

* ours: Gaussian emissions for the states a path can be in (blocks of frames, batch-last) + the
  banded structured forward (log-likelihood) or its gradient (pseudo-state and state posteriors),
  end constraint included.
* dynamax `hmm_filter` / `hmm_smoother` (vmapped, jitted) on the 120-state dense matrix, fed with
  emission log-likelihoods computed by our GEMM emission code in the anchor's own (B, T, K) layout
  (`gaussian_log_density`, one GEMM per block of 512 frames) and gathered to 120 pseudo-states
  (the strong anchor; posteriors as `hmm_filter` x `hmm_backward_filter`, normalised, which is
  `hmm_smoother` without its transition probabilities; like ours it returns pseudo-state and state
  posteriors and the log-likelihoods).
* dynamax `GaussianHMM.marginal_log_prob` / `smoother` (vmapped, jitted): what a dynamax user writes.
* hmmlearn `GaussianHMM.score` / `predict_proba` on all sequences in one call with `lengths` (C,
  float64; rows of the end-state pseudo-states are renormalised, since hmmlearn has no end state).
* online recognition (`experiments.bench.online_stage`): ms per frame of a live stream (2 actions x 1
  stream) and the number of vmapped streams one core keeps at 25 fps.
The anchors have no end constraint: they skip one final logsumexp over a subset, a negligible saving.
float32 everywhere except hmmlearn, which is float64 only: its ratios use our float64 timings.
"""
from __future__ import annotations

import dataclasses
import functools
import time

import jax
import jax.numpy as jnp
import numpy as np

import phmm_jax as P
from experiments.bench.online_stage import online_stage
from experiments.timing import Timing, time_call, time_interleaved
from experiments.config import markdown_table, parse_config
from experiments.data.reaching import movements_at, raster_targets
from lfd_common import enable_compilation_cache
from phmm_jax import batch_log_likelihood, batch_posteriors
from phmm_jax import em_step
from phmm_jax import gaussian_log_density
from phmm_jax import search_parameters


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """phmm_jax vs dynamax vs hmmlearn: log-likelihood and posterior throughput, EM, recognition."""

    seed: int = 0
    batch: int = 280
    n_frames: int = 100
    n_states: int = 20
    min_duration: int = 4
    max_duration: int = 6
    em_sequences: int = 90
    recognition_batch: int = 70
    repeats: int = 7
    hmmlearn_batch: int = 56  # per-sequence cost is flat in B; 280 took minutes per call under load


PRESETS = {
    "quick": {"batch": 56, "em_sequences": 36, "recognition_batch": 20, "repeats": 3, "hmmlearn_batch": 28},
    "paper": {},
}


def make_data(cfg: BenchConfig):
    rng = np.random.default_rng(cfg.seed)
    targets = raster_targets(5, 7).reshape(-1, 3)
    reps = -(-cfg.batch // len(targets))
    X = movements_at(rng, targets, reps, "reaching", cfg.n_frames).reshape(-1, cfg.n_frames, 21)
    return X[rng.permutation(len(X))[: cfg.batch]]


class Table:
    """Rows (what, seq/s, ms per call, compile + first call s) of the throughput table, printed as they come."""

    def __init__(self):
        self.rows = []

    def record(self, name: str, t: Timing, n_seq: int) -> float:
        rate = n_seq / t.median_s
        self.rows.append((name, rate, t.median_s * 1e3, t.first_s - t.median_s))
        print(f"{name:48s} {rate:12.0f} seq/s   {t.median_s * 1e3:9.2f} ms   "
              f"compile+first ~{t.first_s - t.median_s:6.2f} s")
        return rate


FIT_OPTIONS = P.FitOptions(max_iter=10)  # EM of the benchmarked HMM and PHMMs


def fit_model(cfg: BenchConfig, X_np):
    """The benchmarked HMM: fitted by our EM on `em_sequences` simulated reaching movements."""
    hmm_cfg = P.HMMConfig(n_states=cfg.n_states, min_duration=cfg.min_duration, max_duration=cfg.max_duration)
    fit_start = time.perf_counter()
    hmm = P.fit_hmm(X_np[: cfg.em_sequences], config=hmm_cfg, options=FIT_OPTIONS)
    print(f"model fitted by EM in {time.perf_counter() - fit_start:.1f} s (incl. compile)")
    return hmm, hmm_cfg


def dynamax_anchors(hmm):
    """dynamax on the expanded model: (filter, smoother) fed our emission code (per state, gathered to
    pseudo-states), and (log-likelihood, posterior) of `GaussianHMM`, all jitted over (B, T, D)."""
    from dynamax.hidden_markov_model import GaussianHMM, hmm_backward_filter, hmm_filter

    dense = P.expand_to_dense(hmm)
    init = jnp.asarray(np.exp(dense.log_initial), jnp.float32)
    trans = jnp.asarray(np.exp(dense.log_transition), jnp.float32)
    state_of = jnp.asarray(dense.state_of)

    @jax.jit
    def dyn_filter(X):
        log_b = gaussian_log_density(X, hmm.means, hmm.covariances)[..., state_of]
        return jax.vmap(lambda lb: hmm_filter(init, trans, lb).marginal_loglik)(log_b)

    @jax.jit
    def dyn_smoother(X):
        log_b = gaussian_log_density(X, hmm.means, hmm.covariances)[..., state_of]
        # hmm_smoother's compute_trans_probs flag is not static under its own jit, so dynamax always
        # computes transition probabilities there; posteriors alone are its filter and backward
        # filter combined exactly as hmm_smoother does.
        def smooth(lb):
            posterior = hmm_filter(init, trans, lb)
            _, backward = hmm_backward_filter(trans, lb)
            probs = posterior.filtered_probs * backward
            return probs / probs.sum(axis=1, keepdims=True), posterior.marginal_loglik

        # The outputs of ours: pseudo-state and state posteriors (pseudo-states i*P..i*P+P-1 are state
        # i's) and the log-likelihoods.
        pseudo, loglik = jax.vmap(smooth)(log_b)
        return pseudo, pseudo.reshape(*pseudo.shape[:2], hmm.n_states, -1).sum(-1), loglik

    gauss = GaussianHMM(num_states=len(dense.means), emission_dim=hmm.means.shape[-1])
    params, _ = gauss.initialize(initial_probs=init, transition_matrix=trans,
                                 emission_means=jnp.asarray(dense.means, jnp.float32),
                                 emission_covariances=jnp.asarray(dense.covariances, jnp.float32))
    gauss_ll_fn = jax.jit(jax.vmap(lambda x: gauss.marginal_log_prob(params, x)))
    gauss_post_fn = jax.jit(jax.vmap(lambda x: gauss.smoother(params, x).smoothed_probs))
    return dyn_filter, dyn_smoother, gauss_ll_fn, gauss_post_fn


def throughput_stage(cfg: BenchConfig, hmm, X_np, table: Table) -> dict:
    """Log-likelihood and posterior throughput (float32): ours, dynamax fed our emissions, GaussianHMM."""
    X = jnp.asarray(X_np, jnp.float32)
    lengths = jnp.full(cfg.batch, cfg.n_frames, jnp.int32)
    r = cfg.repeats
    dyn_filter, dyn_smoother, gauss_ll_fn, gauss_post_fn = dynamax_anchors(hmm)
    # The sides of the two headline ratios, round-robin: a load that drifts reaches all four alike.
    timed = time_interleaved({"loglik": lambda: batch_log_likelihood(hmm, X, lengths),
                              "posterior": lambda: batch_posteriors(hmm, X, lengths),
                              "filter": lambda: dyn_filter(X), "smoother": lambda: dyn_smoother(X)}, r)
    out = {
        "loglik_seq_per_s": table.record("ours log_likelihood (f32)", timed["loglik"], cfg.batch),
        "posterior_seq_per_s": table.record("ours posteriors (f32)", timed["posterior"], cfg.batch),
        "dynamax_filter_seq_per_s": table.record("dynamax hmm_filter (f32)", timed["filter"], cfg.batch),
        "dynamax_smoother_seq_per_s": table.record("dynamax hmm_smoother (f32)", timed["smoother"], cfg.batch),
    }
    out["dynamax_gaussianhmm_loglik_seq_per_s"] = table.record(
        "dynamax GaussianHMM.marginal_log_prob (f32)", time_call(lambda: gauss_ll_fn(X), r), cfg.batch)
    out["dynamax_gaussianhmm_posterior_seq_per_s"] = table.record(
        "dynamax GaussianHMM.smoother (f32)", time_call(lambda: gauss_post_fn(X), r), cfg.batch)
    # Agreement of the values (the anchors lack the end constraint: compare ours without it too).
    ours_values = np.asarray(batch_log_likelihood(hmm, X, lengths))
    out["max_abs_diff_loglik_vs_dynamax_gaussianhmm_no_end"] = float(np.max(np.abs(
        np.asarray(gauss_ll_fn(X)) - np.asarray(dyn_filter(X)))))
    out["ours_mean_loglik"] = float(ours_values.mean())
    return out


@functools.lru_cache(maxsize=1)  # shared by the recognition and the online stages
def recognition_workload(cfg: BenchConfig, hmm_cfg):
    """The recognition workload: PHMMs of a 2x2 grid for reaching and pointing (one simulated subject
    each, 6 repetitions per corner) and `recognition_batch` pointing movements (each of a new subject)
    to random targets of the 5x7 test raster: (phmms, X (B, T, 21))."""
    rng = np.random.default_rng(cfg.seed + 1)
    corners = raster_targets(2, 2).reshape(-1, 3)
    phmms = [P.fit_phmm(list(movements_at(rng, corners, 6, kind, cfg.n_frames)), (2, 2), hmm_cfg, options=FIT_OPTIONS)
             for kind in ("reaching", "pointing")]
    test_targets = raster_targets(5, 7).reshape(-1, 3)[rng.integers(0, 35, cfg.recognition_batch)]
    X_rec = np.stack([movements_at(rng, t[None], 1, "pointing", cfg.n_frames)[0, 0] for t in test_targets])
    return phmms, X_rec


def em_recognition_stage(cfg: BenchConfig, hmm, hmm_cfg, X_np) -> dict:
    """One EM iteration on `em_sequences` (E + M step, float32); recognition by 2 PHMMs of a 2x2 grid."""
    X_em = jnp.asarray(X_np[: cfg.em_sequences], jnp.float32)
    lengths_em = jnp.full(cfg.em_sequences, cfg.n_frames, jnp.int32)
    weights_em = jnp.ones(cfg.em_sequences, jnp.float32)
    em = time_call(lambda: em_step(hmm, X_em, lengths_em, weights_em, FIT_OPTIONS.reg_covar,
                                   FIT_OPTIONS.duration_pseudocount), cfg.repeats)
    print(f"{'ours EM iteration on ' + str(cfg.em_sequences) + ' sequences':48s} {em.median_s * 1e3:9.2f} ms")

    phmms, X_rec = recognition_workload(cfg, hmm_cfg)
    rec = time_call(lambda: P.recognize(phmms, X_rec).phi, max(1, cfg.repeats // 2))
    recognition_ms = rec.median_s * 1e3 / cfg.recognition_batch
    result = P.recognize(phmms, X_rec)
    accuracy = float(np.mean(np.asarray(result.label) == 1))
    print(f"{'ours recognition (2 classes, phi search)':48s} {recognition_ms:9.2f} ms/seq (batch "
          f"{cfg.recognition_batch}, accuracy {accuracy:.2f})")
    gap = search_gap(result.loglik, dense_search_logliks(phmms, X_rec))
    print(f"{'search gap to a 21^d scan + 30 + 10 steps':48s} within 1 nat {np.mean(gap <= 1):.3f}, median "
          f"{np.median(gap):.3f}, 90th percentile {np.percentile(gap, 90):.2f}, max {gap.max():.1f} nats")
    return {"em_iteration_s": em.median_s, "em_iteration_compile_s": em.first_s - em.median_s,
            "recognition_ms_per_seq": recognition_ms, "recognition_accuracy_pointing": accuracy,
            "recognition_at_max_rate": float(np.mean(gap <= 1)), "search_gap_median": float(np.median(gap)),
            "search_gap_p90": float(np.percentile(gap, 90)), "search_gap_max": float(gap.max())}


def dense_search_logliks(phmms, X) -> np.ndarray:
    """(B, K) the log-likelihood per sequence and PHMM of a dense search: the best of a 21^d lattice,
    30 quasi-Newton steps and the grid-line probe with 10 more (the reference of `search_gap`)."""
    X = jnp.asarray(X, jnp.float32)
    lengths = jnp.full(X.shape[0], X.shape[1], jnp.int32)
    return np.stack([np.asarray(search_parameters(p, X, lengths, 0.1, 30, 21, 10)[1]) for p in phmms], axis=1)


def search_gap(loglik, dense: np.ndarray) -> np.ndarray:
    """(B * K,) how far `recognize`'s log-likelihoods (B, K) fall below `dense_search_logliks`' (B, K),
    0 where it does better."""
    return np.maximum(dense - np.asarray(loglik), 0.0).ravel()


def hmmlearn_stage(cfg: BenchConfig, hmm, X_np, table: Table) -> dict:
    """hmmlearn (float64 only) on `hmmlearn_batch` sequences, and ours in float64 on the whole batch."""
    from hmmlearn.hmm import GaussianHMM as HmmlearnGaussian

    dense = P.expand_to_dense(hmm)
    ref = HmmlearnGaussian(n_components=len(dense.means), covariance_type="full", implementation="log")
    ref.n_features = X_np.shape[-1]
    ref.startprob_ = np.exp(dense.log_initial)
    transmat = np.exp(dense.log_transition)
    row = transmat.sum(axis=1, keepdims=True)
    ref.transmat_ = np.where(row > 0, transmat / np.where(row > 0, row, 1), np.eye(len(row)))
    ref.means_ = dense.means
    ref.covars_ = dense.covariances
    nb = cfg.hmmlearn_batch
    flat = X_np[:nb].reshape(-1, X_np.shape[-1])
    seq_lengths = [cfg.n_frames] * nb
    r = max(1, cfg.repeats // 3)
    out = {"hmmlearn_score_seq_per_s": table.record("hmmlearn score (f64)",
                                                    time_call(lambda: ref.score(flat, seq_lengths), r), nb),
           "hmmlearn_posterior_seq_per_s": table.record(
               "hmmlearn predict_proba (f64)", time_call(lambda: ref.predict_proba(flat, seq_lengths), r), nb)}
    lengths = jnp.full(cfg.batch, cfg.n_frames, jnp.int32)
    jax.config.update("jax_enable_x64", True)
    hmm64 = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float64), hmm)
    X64 = jnp.asarray(X_np, jnp.float64)
    out["loglik_f64_seq_per_s"] = table.record(
        "ours log_likelihood (f64)", time_call(lambda: batch_log_likelihood(hmm64, X64, lengths), cfg.repeats),
        cfg.batch)
    out["posterior_f64_seq_per_s"] = table.record(
        "ours posteriors (f64)", time_call(lambda: batch_posteriors(hmm64, X64, lengths), cfg.repeats), cfg.batch)
    jax.config.update("jax_enable_x64", False)
    return out


RATIOS = {  # ratio key -> (ours, anchor)
    "ratio_loglik_vs_dynamax": ("loglik_seq_per_s", "dynamax_filter_seq_per_s"),
    "ratio_posterior_vs_dynamax": ("posterior_seq_per_s", "dynamax_smoother_seq_per_s"),
    "ratio_loglik_vs_dynamax_gaussianhmm": ("loglik_seq_per_s", "dynamax_gaussianhmm_loglik_seq_per_s"),
    "ratio_posterior_vs_dynamax_gaussianhmm": ("posterior_seq_per_s", "dynamax_gaussianhmm_posterior_seq_per_s"),
    "ratio_loglik_vs_hmmlearn": ("loglik_f64_seq_per_s", "hmmlearn_score_seq_per_s"),
    "ratio_posterior_vs_hmmlearn": ("posterior_f64_seq_per_s", "hmmlearn_posterior_seq_per_s"),
}


def report(cfg: BenchConfig, results: dict, table: Table) -> str:
    ratios = {k: v for k, v in results.items() if k.startswith("ratio_")}
    return "\n".join([
        "# HMM benchmark: phmm_jax vs dynamax vs hmmlearn", "",
        f"B = {cfg.batch}, T = {cfg.n_frames}, N = {cfg.n_states} x durations {cfg.min_duration}-{cfg.max_duration} "
        f"({results['n_pseudo_states']} pseudo-states), D = {results['dim']}, full covariance, on {results['device']}.",
        "hmmlearn scored {} sequences (float64).".format(cfg.hmmlearn_batch), "",
        markdown_table(["what", "seq/s", "ms per call", "compile + first call (s)"], table.rows), "",
        markdown_table(["ratio", "value"], list(ratios.items())), "",
        f"EM iteration on {cfg.em_sequences} sequences: {results['em_iteration_s']:.3f} s. Recognition: "
        f"{results['recognition_ms_per_seq']:.2f} ms per sequence (batch {cfg.recognition_batch}, 2 PHMMs of a "
        f"2x2 grid); within 1 nat of a dense search (21^d lattice, 30 + 10 steps) in "
        f"{results['recognition_at_max_rate']:.1%} of sequence-PHMM pairs (median gap {results['search_gap_median']:.3f}, "
        f"max {results['search_gap_max']:.1f} nats).",
    ])


def main(argv=None) -> dict:
    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_hmm", argv=argv)
    enable_compilation_cache()
    X_np = make_data(cfg)
    hmm, hmm_cfg = fit_model(cfg, X_np)
    table = Table()
    results = {"batch": cfg.batch, "n_frames": cfg.n_frames, "n_pseudo_states": cfg.n_states * cfg.max_duration,
               "dim": X_np.shape[-1], "device": str(jax.devices()[0]),
               **throughput_stage(cfg, hmm, X_np, table), **em_recognition_stage(cfg, hmm, hmm_cfg, X_np),
               **hmmlearn_stage(cfg, hmm, X_np, table),
               **online_stage(recognition_workload(cfg, hmm_cfg)[0], cfg.seed, cfg.repeats)}
    results.update({k: results[a] / results[b] for k, (a, b) in RATIOS.items()})
    for key in RATIOS:
        print(f"{key:45s} {results[key]:8.2f}x")
    run.write(results, report(cfg, results, table), filename="bench.json", flat=False)
    print(f"wrote {run.path / 'bench.json'}")
    return results


if __name__ == "__main__":
    main()
