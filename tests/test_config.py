import dataclasses
import json

import numpy as np
import pytest

from experiments.config import build_parser, markdown_table, parse_config, resolve_config


@dataclasses.dataclass(frozen=True)
class Cfg:
    """A test experiment."""

    seed: int = 0
    n_states: int = 20
    noise_cm: float = 0.0
    grid: tuple[int, ...] = (3, 3)
    full_covariance: bool = True
    label: str = "pointing"
    limit: int | None = None


PRESETS = {"quick": {"n_states": 5}, "paper": {"n_states": 20, "grid": (2, 2)}}


def test_defaults_then_preset_then_flags(tmp_path):
    cfg, _ = parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path)])
    assert cfg == Cfg(n_states=5)  # quick is the default preset
    cfg, _ = parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path), "--preset", "paper"])
    assert cfg.n_states == 20 and cfg.grid == (2, 2)
    cfg, _ = parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path), "--preset", "paper", "--n-states", "7",
                                              "--grid", "2,2,2", "--full-covariance", "false",
                                              "--noise-cm", "1.5", "--seed", "3", "--label", "reaching",
                                              "--limit", "none"])
    assert cfg == Cfg(seed=3, n_states=7, noise_cm=1.5, grid=(2, 2, 2), full_covariance=False,
                      label="reaching", limit=None)
    cfg, _ = parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path), "--limit", "4"])
    assert cfg.limit == 4


def test_bad_flag_values_exit_with_usage(tmp_path, capsys):
    with pytest.raises(SystemExit):
        parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path), "--n-states", "many"])
    with pytest.raises(SystemExit):
        parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path), "--preset", "huge"])
    with pytest.raises(SystemExit):
        parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path), "--full-covariance", "maybe"])
    assert "usage:" in capsys.readouterr().err


def test_help_lists_every_field(capsys):
    parser = build_parser(Cfg, PRESETS, "t")
    text = parser.format_help()
    for flag in ("--preset", "--out", "--seed", "--n-states", "--noise-cm", "--grid", "--full-covariance",
                 "--label", "--limit"):
        assert flag in text
    assert "quick: 5" in text


def test_config_class_requirements():
    @dataclasses.dataclass(frozen=True)
    class NoSeed:
        n: int = 1

    @dataclasses.dataclass
    class NotFrozen:
        seed: int = 0

    with pytest.raises(TypeError, match="seed"):
        build_parser(NoSeed, {}, "t")
    with pytest.raises(TypeError, match="frozen"):
        build_parser(NotFrozen, {}, "t")
    with pytest.raises(TypeError, match="unknown fields"):
        build_parser(Cfg, {"quick": {"n_stat": 1}}, "t")
    with pytest.raises(ValueError, match="preset"):
        resolve_config(Cfg, PRESETS, "nope", {})


def test_run_output_files(tmp_path):
    cfg, run = parse_config(Cfg, PRESETS, "t", ["--out", str(tmp_path / "run")])
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["n_states"] == 5 and saved["preset"] == "quick" and saved["grid"] == [3, 3]
    run.write_metrics({"accuracy_pct": np.float32(93.5), "n_test": np.int64(280), "ok": np.bool_(True),
                       "loglik": float("-inf")})
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics == {"accuracy_pct": 93.5, "n_test": 280, "ok": True, "loglik": "-inf"}
    with pytest.raises(ValueError, match=r"metrics\['curve'\]"):
        run.write_metrics({"curve": np.zeros(3)})
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    png = run.save_figure(fig, "plot.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    run.write_report("# r\n\n" + markdown_table(["a", "b"], [(1, 0.123456)]))
    assert "| 1 | 0.1235 |" in (tmp_path / "run" / "report.md").read_text()


def test_default_out_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _, run = parse_config(Cfg, PRESETS, "exp", [])
    assert run.path.parent == tmp_path.joinpath("runs", "exp").relative_to(tmp_path)
    assert (tmp_path / run.path / "config.json").exists()


def test_writer_flattens_nested_metrics(tmp_path):
    from experiments.config import RunOutput, StageResult, flatten_metrics

    assert flatten_metrics({"a": {"b": 1, "c": {"d_cm": 2.0}}, "e": 3}) == {"a_b": 1, "a_c_d_cm": 2.0, "e": 3}
    assert flatten_metrics({"rate_x": 0.5, "rate": {"x": 0.5}}) == {"rate_x": 0.5}  # the same key, the same value
    with pytest.raises(ValueError, match="rate_x"):
        flatten_metrics({"rate_x": 0.5, "rate": {"x": 0.25}})
    run = RunOutput(tmp_path / "run", "t")
    written = run.write({"error_cm": {"inner": np.float32(1.5), "noise": {"10cm": float("nan")}},
                         "confusion": [[1, 0], [np.int64(2), 3]]}, "# r", {"img.png": np.zeros((4, 5, 3))})
    saved = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert saved == written == {"error_cm_inner": 1.5, "error_cm_noise_10cm": "nan", "confusion": [[1, 0], [2, 3]]}
    assert (tmp_path / "run" / "img.png").read_bytes()[:4] == b"\x89PNG"
    bench = run.write({"ratio": {"5400": 2.0}, "config": {"sizes": (1, 2)}}, filename="bench.json", flat=False)
    assert bench == json.loads((tmp_path / "run" / "bench.json").read_text()) == {
        "ratio": {"5400": 2.0}, "config": {"sizes": [1, 2]}}
    stages = [StageResult({"a": {"x_s": 1.0}}, {}, "## one"), StageResult({"b_s": 2.0}, {"sub/img.png": np.ones((2, 2, 3))},
                                                                           files={"v/clip.bin": lambda p: p.write_bytes(b"ab")})]
    assert run.write_stages(stages, "# header", total_s=3.0) == {"a_x_s": 1.0, "b_s": 2.0, "total_s": 3.0}
    assert (tmp_path / "run" / "report.md").read_text() == "# header\n\n## one\n"
    assert (tmp_path / "run" / "sub" / "img.png").exists()
    assert (tmp_path / "run" / "v" / "clip.bin").read_bytes() == b"ab"   # a file stage writes where it is told


def test_timing_helper():
    import jax.numpy as jnp

    from experiments.timing import time_call

    calls = []
    t = time_call(lambda: calls.append(1) or jnp.ones(3) * len(calls), repeats=3)
    assert len(calls) == 4 and len(t.times_s) == 3 and float(t.result[0]) == 4.0
    assert t.median_s >= 0 and t.compile_s >= 0 and t.first_s == t.first_s
    made = []
    t = time_call(lambda x: x + 1, repeats=2, warmup=None, setup=lambda: made.append(0) or len(made), block=False)
    assert made == [0, 0] and t.result == 3 and t.first_s != t.first_s and t.compile_s == 0.0
    t = time_call(lambda: "full", repeats=1, warmup=lambda: calls.append("small"))
    assert calls[-1] == "small" and t.result == "full"
    with pytest.raises(ValueError, match="repeats"):
        time_call(lambda: None, repeats=0)


def test_interleaved_timing_calls_each_side_in_turn():
    from experiments.timing import time_interleaved

    order = []
    timed = time_interleaved({"a": lambda: order.append("a") or 1, "b": lambda: order.append("b") or 2}, repeats=3,
                             block=False)
    assert order == ["a", "b"] * 4  # one warm-up round, then three timed rounds
    assert [len(t.times_s) for t in timed.values()] == [3, 3] and (timed["a"].result, timed["b"].result) == (1, 2)
    with pytest.raises(ValueError, match="repeats"):
        time_interleaved({"a": lambda: None}, repeats=0)
