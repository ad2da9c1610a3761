"""Linear-chain CRF benchmark: crf_jax (optax L-BFGS, jit) against sklearn-crfsuite (CRFsuite, L-BFGS).

    python -m experiments.bench.bench_crf --preset quick --out runs/bench_crf

Both sides fit the SAME model to the SAME data with the SAME objective:
    sum_b -log P(y_b | x_b) + c2 * ||theta||^2,
    log P(y | x) = sum_t (<w_{y_t}, x_t> + b_{y_t}) + sum_{t>=1} trans[y_{t-1}, y_t] - log Z(x)
(connectivity 0, dense real-valued features; CRFsuite gets every frame as {"f0": x_0, ..., "bias": 1.0},
all (attribute, label) state features and all transitions (`feature.possible_states`,
`feature.possible_transitions`, and `feature.minfreq = -1e300`: CRFsuite's feature "frequency" is the
summed attribute VALUE, so with real-valued features of either sign the default minfreq 0 silently drops
about half the state features), so its parameter vector is exactly
(weights, bias, trans) of `crf_jax.ChainCRF`), the same L-BFGS history size and the same stopping rule
(relative improvement < delta over `period` iterations, or ||g|| / max(1, ||w||) < 1e-5: CRFsuite's
defaults). Differences that remain: crf_jax computes in float32 (CRFsuite in float64) and uses optax's
zoom (strong Wolfe) line search, CRFsuite More-Thuente; so the two stop after different numbers of
iterations at slightly different objectives (both are printed and stored). Data: labels from a
sticky HMM-like Markov chain, features class-conditional Gaussian means plus AR(1) noise.

Timed, each side from its own input format to its result, warm (compile time reported apart):
* crf_jax train: numpy arrays -> validated batch -> `crf_jax.fit_chain` (device) -> parameters.
* CRFsuite train: `Trainer.train` only (data already appended); the numpy -> dict conversion and
  the `append` (loading into CRFsuite) are reported separately.
* inference: Viterbi labelling of the test set; CRFsuite `Tagger.tag` per sequence (dicts prebuilt,
  conversion timed apart), crf_jax `crf_jax.predict` on the padded batch.
"""
from __future__ import annotations

import dataclasses
import os
import tempfile
import time

import numpy as np

from experiments.timing import time_call
from experiments.config import parse_config
from lfd_common import enable_compilation_cache


@dataclasses.dataclass(frozen=True)
class BenchConfig:
    """Linear-chain CRF: crf_jax vs sklearn-crfsuite, same data, features and L2."""

    seed: int = 0
    n_train: int = 2000
    n_test: int = 500
    seq_len: int = 100
    n_features: int = 100
    n_labels: int = 10
    c2: float = 1.0
    max_iter: int = 200
    memory_size: int = 6
    delta: float = 1e-5
    period: int = 10
    stay_prob: float = 0.85
    separation: float = 0.75
    noise_ar: float = 0.5
    repeats: int = 3

    def __post_init__(self):
        if min(self.n_train, self.n_test, self.seq_len, self.n_features, self.n_labels, self.max_iter,
               self.repeats) < 1:
            raise ValueError("sizes, max_iter and repeats must be positive")
        if self.n_labels < 2:
            raise ValueError("n_labels must be >= 2")


PRESETS = {
    "quick": {"n_train": 200, "n_test": 100, "seq_len": 50, "n_features": 30, "n_labels": 5, "repeats": 1},
    "paper": {},
}


def make_data(cfg: BenchConfig, n_seq: int, rng: np.random.Generator, params=None):
    """Sequences from a sticky Markov label process with class-conditional Gaussian features.

    Labels: y_1 uniform, y_t = y_{t-1} with prob `stay_prob`, else a jump drawn from a fixed random
    (Dirichlet(1)) distribution over the other labels. Features: x_t = mu_{y_t} + e_t with
    mu_k ~ N(0, separation^2 / sqrt(D) I) fixed per data set and AR(1) noise
    e_t = a e_{t-1} + sqrt(1 - a^2) n_t, n_t ~ N(0, I). Returns X (B, T, D) float32, y (B, T) int32, params.
    """
    K, D, T = cfg.n_labels, cfg.n_features, cfg.seq_len
    if params is None:
        jump = rng.dirichlet(np.ones(K - 1), size=K)
        A = np.zeros((K, K))
        for k in range(K):
            A[k, np.arange(K) != k] = (1 - cfg.stay_prob) * jump[k]
            A[k, k] = cfg.stay_prob
        mu = rng.normal(size=(K, D)) * cfg.separation / D ** 0.25
        params = (A, mu)
    A, mu = params
    y = np.empty((n_seq, T), np.int32)
    y[:, 0] = rng.integers(0, K, n_seq)
    cum = np.cumsum(A, axis=1)
    for t in range(1, T):
        u = rng.random(n_seq)[:, None]
        y[:, t] = np.minimum((u > cum[y[:, t - 1]]).sum(axis=1), K - 1)
    e = np.empty((n_seq, T, D))
    e[:, 0] = rng.normal(size=(n_seq, D))
    a = cfg.noise_ar
    for t in range(1, T):
        e[:, t] = a * e[:, t - 1] + np.sqrt(1 - a * a) * rng.normal(size=(n_seq, D))
    X = (mu[y] + e).astype(np.float32)
    return X, y, params


def to_crfsuite(X: np.ndarray, y: np.ndarray | None = None):
    """Per-frame feature dicts {"f0": value, ..., "bias": 1.0} and string labels."""
    names = [f"f{j}" for j in range(X.shape[2])]
    xs = [[{**dict(zip(names, frame.tolist())), "bias": 1.0} for frame in seq] for seq in X]
    ys = None if y is None else [[str(v) for v in seq] for seq in y.tolist()]
    return xs, ys


def crf_jax_stage(cfg: BenchConfig, data) -> dict:
    """crf_jax: training (numpy -> fit_chain -> parameters, warm; compile apart) and Viterbi on the test set."""
    import crf_jax

    X_tr, y_tr, X_te, y_te = data
    options = crf_jax.FitOptions(method="lbfgs", max_iter=cfg.max_iter, memory_size=cfg.memory_size,
                                 delta=cfg.delta, period=cfg.period)
    fit_kw = dict(n_labels=cfg.n_labels, l2=cfg.c2, options=options)
    train = time_call(lambda: crf_jax.fit_chain(X_tr, y_tr, **fit_kw), cfg.repeats)
    model, info = train.result
    obj = float(-np.sum(np.asarray(crf_jax.log_likelihood(model, X_tr, y_tr)))
                + cfg.c2 * sum(float(np.sum(np.square(np.asarray(p)))) for p in model))
    infer = time_call(lambda: np.asarray(crf_jax.predict(model, X_te)), cfg.repeats,
                      warmup=lambda: crf_jax.predict(model, X_te))
    out = {"train_s_crf_jax": train.median_s, "train_first_call_s_crf_jax": train.first_s,
           "compile_s_crf_jax_approx": train.first_s - train.median_s, "iterations_crf_jax": int(info.n_iter),
           "objective_crf_jax": obj, "inference_s_crf_jax": infer.median_s,
           "accuracy_crf_jax": float(np.mean(infer.result == y_te))}
    print(f"crf_jax: train {out['train_s_crf_jax']:.3f} s ({out['iterations_crf_jax']} iterations, first call incl. "
          f"compile {train.first_s:.3f} s), objective {obj:.4f}, test accuracy {out['accuracy_crf_jax']:.4f}, "
          f"inference {infer.median_s:.4f} s")
    return out


def crfsuite_stage(cfg: BenchConfig, data) -> dict:
    """CRFsuite: dict conversion, `append` and `Trainer.train` timed apart; `Tagger.tag` per test sequence."""
    import pycrfsuite

    X_tr, y_tr, X_te, y_te = data
    t0 = time.perf_counter()
    xs_tr, ys_tr = to_crfsuite(X_tr, y_tr)
    xs_te, _ = to_crfsuite(X_te)
    convert_s = time.perf_counter() - t0

    def trainer():
        t = pycrfsuite.Trainer(algorithm="lbfgs", verbose=False)
        t.set_params({
            "c1": 0.0, "c2": cfg.c2, "feature.minfreq": -1e300, "max_iterations": cfg.max_iter,
            "num_memories": cfg.memory_size, "delta": cfg.delta, "period": cfg.period,
            "feature.possible_states": True, "feature.possible_transitions": True,
        })
        return t

    def append(t):
        for xseq, yseq in zip(xs_tr, ys_tr):
            t.append(xseq, yseq)
        return t

    with tempfile.TemporaryDirectory() as tmp:
        model_path = os.path.join(tmp, "crf.crfsuite")
        appended = time_call(append, cfg.repeats, warmup=None, setup=trainer, block=False)
        train = time_call(lambda t: (t.train(model_path), t)[1], cfg.repeats, warmup=None,
                          setup=lambda: append(trainer()), block=False)
        log = train.result.logparser
        n_iter = len(log.iterations)
        obj = float(log.iterations[-1]["loss"]) if log.iterations else float("nan")
        tagger = pycrfsuite.Tagger()
        tagger.open(model_path)
        infer = time_call(lambda: [tagger.tag(xseq) for xseq in xs_te], cfg.repeats, warmup=None, block=False)
        tagger.close()
    out = {"train_s_crfsuite": train.median_s, "append_s_crfsuite": appended.median_s,
           "dict_conversion_s_crfsuite": convert_s, "inference_s_crfsuite": infer.median_s,
           "iterations_crfsuite": n_iter, "objective_crfsuite": obj,
           "accuracy_crfsuite": float(np.mean(np.array([[int(v) for v in seq] for seq in infer.result]) == y_te))}
    print(f"crfsuite: train {train.median_s:.3f} s ({n_iter} iterations), append {appended.median_s:.3f} s, "
          f"dict conversion (train+test) {convert_s:.3f} s, objective {obj:.4f}, "
          f"test accuracy {out['accuracy_crfsuite']:.4f}, inference {infer.median_s:.4f} s")
    return out


def main(argv=None):
    enable_compilation_cache()
    import jax

    cfg, run = parse_config(BenchConfig, PRESETS, name="bench.bench_crf", argv=argv)
    rng = np.random.default_rng(cfg.seed)
    X_tr, y_tr, params = make_data(cfg, cfg.n_train, rng)
    X_te, y_te, _ = make_data(cfg, cfg.n_test, rng, params)
    print(f"data: train {X_tr.shape}, test {X_te.shape}, {cfg.n_labels} labels, c2={cfg.c2}")
    data = (X_tr, y_tr, X_te, y_te)
    ours, anchor = crf_jax_stage(cfg, data), crfsuite_stage(cfg, data)
    result = {
        "ratio_train_vs_crfsuite": anchor["train_s_crfsuite"] / ours["train_s_crf_jax"],
        "ratio_train_vs_crfsuite_incl_append": (anchor["train_s_crfsuite"] + anchor["append_s_crfsuite"])
        / ours["train_s_crf_jax"],
        "ratio_inference_vs_crfsuite": anchor["inference_s_crfsuite"] / ours["inference_s_crf_jax"],
        **ours, **anchor,
        "inference_seq_per_s_crf_jax": cfg.n_test / ours["inference_s_crf_jax"],
        "inference_seq_per_s_crfsuite": cfg.n_test / anchor["inference_s_crfsuite"],
        "device": str(jax.devices()[0]),
        "config": dataclasses.asdict(cfg),
    }
    run.write(result, filename="bench.json", flat=False)
    for key in ("ratio_train_vs_crfsuite", "ratio_train_vs_crfsuite_incl_append", "ratio_inference_vs_crfsuite",
                "accuracy_crf_jax", "accuracy_crfsuite"):
        print(f"{key}: {result[key]:.4f}")
    print(f"wrote {run.file('bench.json')}")
    return result


if __name__ == "__main__":
    main()
