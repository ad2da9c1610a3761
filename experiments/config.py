"""Frozen-dataclass configs as command-line flags, and the output folder every experiment writes.

An experiment declares a frozen dataclass (with a `seed: int` field) and its presets::

    @dataclasses.dataclass(frozen=True)
    class Config:
        seed: int = 0
        n_worlds: int = 64

    PRESETS = {"quick": {"n_worlds": 8}, "paper": {}}
    cfg, run = parse_config(Config, PRESETS, name="demo")

The command line then accepts `--preset quick|paper` (default quick), `--out DIR` (default
`runs/<name>/<timestamp>`), `--seed S` and one `--field-name value` per field. Values resolve as
field default < preset < explicit flag. `run` is a `RunOutput`, the one writer of `config.json`,
`metrics.json`, `report.md` and figures in the output folder: an experiment is a few stages that
each return a `StageResult` (nested metrics, figures, a report section), and its `main` writes them
with one `run.write(...)` / `run.write_stages(...)` call. Nested metrics are written flattened, keys
joined by "_" (`{"param_error_cm_noise": {"10cm": x}}` -> `param_error_cm_noise_10cm`).
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import importlib.metadata
import json
import math
import numbers
import os
import platform
import shlex
import subprocess
import sys
import time
import types
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from lfd_common import markdown_table, progress  # noqa: F401  (re-exported for the studies)

C = TypeVar("C")
_TUPLE_SEP = ","


def _field_parser(annotation: Any, field_name: str):
    """Return (argparse type callable, nargs-free) for a dataclass field annotation."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(args) != 1:
            raise TypeError(f"config field {field_name!r}: unions other than Optional[T] are not supported")
        inner = _field_parser(args[0], field_name)

        def parse_optional(text: str):
            return None if text.lower() == "none" else inner(text)

        return parse_optional
    if origin is tuple:
        args = typing.get_args(annotation)
        elem = args[0] if args else str
        elem_parse = _field_parser(elem, field_name)

        def parse_tuple(text: str):
            return tuple(elem_parse(part.strip()) for part in text.split(_TUPLE_SEP) if part.strip())

        return parse_tuple
    if annotation is bool:
        return _parse_bool
    if annotation in (int, float, str):
        return annotation
    if isinstance(annotation, type) and issubclass(annotation, Path):
        return Path
    raise TypeError(f"config field {field_name!r}: unsupported type {annotation!r}")


def _parse_bool(text: str) -> bool:
    low = text.lower()
    if low in ("1", "true", "yes", "on"):
        return True
    if low in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"expected true/false, got {text!r}")


def _flag(field_name: str) -> str:
    return "--" + field_name.replace("_", "-")


def build_parser(config_cls: type, presets: Mapping[str, Mapping[str, Any]], name: str, description: str | None = None):
    """An `argparse.ArgumentParser` with --preset, --out and one flag per config field."""
    if not (dataclasses.is_dataclass(config_cls) and config_cls.__dataclass_params__.frozen):
        raise TypeError(f"{config_cls!r} must be a frozen dataclass")
    hints = typing.get_type_hints(config_cls)
    fields = dataclasses.fields(config_cls)
    if "seed" not in {f.name for f in fields}:
        raise TypeError(f"{config_cls.__name__} must have a `seed: int` field")
    for preset, values in presets.items():
        unknown = set(values) - {f.name for f in fields}
        if unknown:
            raise TypeError(f"preset {preset!r} sets unknown fields {sorted(unknown)}")
    parser = argparse.ArgumentParser(
        prog=f"python -m experiments.{name}",
        description=description or (config_cls.__doc__ or "").strip(),
    )
    default_preset = "quick" if "quick" in presets else None
    parser.add_argument("--preset", choices=sorted(presets), default=default_preset,
                        help=f"named set of field values; explicit flags override it (default {default_preset})")
    parser.add_argument("--out", type=Path, default=None,
                        help=f"output folder (default: runs/{name}/<timestamp>)")
    defaults = config_cls()
    for field in fields:
        parse = _field_parser(hints[field.name], field.name)
        default = getattr(defaults, field.name)
        shown = _TUPLE_SEP.join(map(str, default)) if isinstance(default, tuple) else default
        preset_note = "; ".join(f"{p}: {v[field.name]}" for p, v in presets.items() if field.name in v)
        help_text = f"default {shown}" + (f" ({preset_note})" if preset_note else "")
        parser.add_argument(_flag(field.name), dest=field.name, type=parse, default=argparse.SUPPRESS,
                            metavar=field.name.upper(),
                            help=help_text)
    return parser


def resolve_config(config_cls: type[C], presets: Mapping[str, Mapping[str, Any]], preset: str | None,
                   overrides: Mapping[str, Any]) -> C:
    """Field defaults, then the preset's values, then `overrides`."""
    values: dict[str, Any] = {}
    if preset is not None:
        if preset not in presets:
            raise ValueError(f"preset: expected one of {sorted(presets)}, got {preset!r}")
        values.update(presets[preset])
    values.update(overrides)
    return dataclasses.replace(config_cls(), **values)


def parse_config(config_cls: type[C], presets: Mapping[str, Mapping[str, Any]], name: str,
                 argv: Sequence[str] | None = None, description: str | None = None) -> tuple[C, "RunOutput"]:
    """Parse the command line into a config and an output folder (created, with `config.json`)."""
    parser = build_parser(config_cls, presets, name, description)
    args = vars(parser.parse_args(argv))
    preset = args.pop("preset")
    out = args.pop("out")
    try:
        cfg = resolve_config(config_cls, presets, preset, args)
    except ValueError as err:  # a config's __post_init__ validation
        parser.error(str(err))
    if out is None:
        out = Path("runs") / name / _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    run = RunOutput(Path(out), name)
    run.write_json("config.json", {"experiment": name, "preset": preset, **dataclasses.asdict(cfg)})
    run.write_json("run.json", run_info(name, argv))
    return cfg, run


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _git_describe() -> str | None:
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], capture_output=True, text=True,
                             cwd=Path(__file__).resolve().parent, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def run_info(name: str, argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Where a run comes from, written as `run.json` beside its config.

    Args:
        name: The experiment's module under `experiments` (e.g. `phmm_tabletop`, `bench.bench_hmm`).
        argv: The run's arguments (default: the process's own, `sys.argv[1:]`).

    Returns:
        The command that reproduces the run, its arguments, the installed `lfd-jax` version (None when
        the package is not installed), the UTC start time, the machine (platform, Python, CPU model and
        count) and `git describe` of the source tree (None outside a git checkout).
    """
    args = [str(a) for a in (sys.argv[1:] if argv is None else argv)]
    try:
        version = importlib.metadata.version("lfd-jax")
    except importlib.metadata.PackageNotFoundError:
        version = None
    return {"command": shlex.join(["python", "-m", f"experiments.{name}", *args]), "argv": args,
            "version": version, "started_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "platform": platform.platform(), "python": platform.python_version(), "cpu": _cpu_model(),
            "cpu_count": os.cpu_count(), "git": _git_describe()}


def _json_value(key: str, value: Any) -> Any:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        value = float(value)
        return value if math.isfinite(value) else str(value)
    if isinstance(value, str) or value is None:
        return value
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return _json_value(key, value.item())
    if isinstance(value, (list, tuple)):  # a short list of scalars (a confusion matrix row, labels)
        return [_json_value(f"{key}[{i}]", v) for i, v in enumerate(value)]
    raise ValueError(f"metrics[{key!r}]: expected a scalar, a list of scalars or a dict of them "
                     f"(units in the key names), got {type(value).__name__}")


def flatten_metrics(metrics: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested metrics -> one flat dict: {"a": {"b": 1}} -> {"a_b": 1} (keys joined by "_"). A key that
    comes out twice must carry the same value both times, else ValueError."""
    flat: dict[str, Any] = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        items = flatten_metrics(value, name + "_").items() if isinstance(value, Mapping) else [(name, value)]
        for k, v in items:
            if k in flat and _json_value(k, flat[k]) != _json_value(k, v):
                raise ValueError(f"metrics[{k!r}]: given twice with different values ({flat[k]!r}, {v!r})")
            flat[k] = v
    return flat


def _json_tree(key: str, value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _json_tree(f"{key}.{k}", v) for k, v in value.items()}
    return _json_value(key, value)


@dataclasses.dataclass
class StageResult:
    """What one stage of an experiment returns: metrics (nested dicts allowed, units in the key
    names), figures (file name -> matplotlib figure or (H, W, 3|4) image array), a report section, and
    files that are neither (file name -> a function that writes it at the path it is given, e.g. a
    video, and returns the path written)."""

    metrics: dict = dataclasses.field(default_factory=dict)
    figures: dict = dataclasses.field(default_factory=dict)
    report: str = ""
    files: dict = dataclasses.field(default_factory=dict)


class RunOutput:
    """The output folder of one run, and its one writer: `config.json`, `metrics.json`, `report.md`,
    figures. An experiment's `main` ends in one `write(...)` call."""

    def __init__(self, path: Path, name: str):
        self.path = Path(path)
        self.name = name
        self.path.mkdir(parents=True, exist_ok=True)
        self._started = time.monotonic()

    def file(self, filename: str) -> Path:
        return self.path / filename

    def write_json(self, filename: str, data: Any) -> Path:
        target = self.file(filename)
        target.write_text(json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")
        return target

    def write(self, metrics: Mapping[str, Any], report: str | None = None, figures: Mapping[str, Any] | None = None,
              *, filename: str = "metrics.json", flat: bool = True) -> dict[str, Any]:
        """Save `figures`, then `metrics` as `filename` (flattened: `flatten_metrics`; with
        `flat=False` kept nested, for a benchmark's `bench.json`), then `report` as report.md.
        Returns the metrics as written."""
        for name, figure in (figures or {}).items():
            self.save_figure(figure, name)
        if flat:
            written = {k: _json_value(k, v) for k, v in flatten_metrics(metrics).items()}
        else:
            written = _json_tree("", metrics)
        self.write_json(filename, written)
        if report is not None:
            self.write_report(report)
        self._finish_run_info()
        return written

    def _finish_run_info(self) -> None:
        """Add the end time, the wall time and the JAX devices used to `run.json`, when the run has one."""
        target = self.file("run.json")
        if not target.is_file():
            return
        info = json.loads(target.read_text())
        info["finished_utc"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        info["wall_s"] = round(time.monotonic() - self._started, 1)
        if "jax" in sys.modules:  # a run that used JAX: name its devices (importing JAX here would cost seconds)
            devices = sys.modules["jax"].devices()
            info["devices"] = sorted({f"{d.platform}:{getattr(d, 'device_kind', '')}" for d in devices})
            info["device_count"] = len(devices)
        self.write_json("run.json", info)

    def write_stages(self, results: Sequence[StageResult], header: str = "", **extra_metrics) -> dict[str, Any]:
        """`write` for a run made of stages: their metrics merged (plus `extra_metrics`), their figures
        and files, and the report `header` followed by every stage's section."""
        metrics: dict[str, Any] = {}
        figures: dict[str, Any] = {}
        for result in results:
            metrics.update(result.metrics)
            figures.update(result.figures)
            for name, write in result.files.items():
                target = self.file(name)
                target.parent.mkdir(parents=True, exist_ok=True)
                write(target)
        metrics.update(extra_metrics)
        sections = [header] + [r.report for r in results if r.report]
        return self.write(metrics, "\n\n".join(s for s in sections if s), figures)

    def write_metrics(self, metrics: Mapping[str, Any]) -> Path:
        """Write scalar metrics, nested dicts flattened (NaN/inf are stored as strings so the JSON stays valid)."""
        self.write(metrics)
        return self.file("metrics.json")

    def write_report(self, markdown: str) -> Path:
        target = self.file("report.md")
        target.write_text(markdown.rstrip() + "\n")
        return target

    def save_figure(self, fig, filename: str, dpi: int = 120) -> Path:
        """Save a matplotlib figure (closed afterwards) or an image array (H, W, 3|4) as PNG under the run folder."""
        import matplotlib.pyplot as plt

        target = self.file(filename)
        target.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(fig, np.ndarray):
            plt.imsave(target, fig)
            return target
        fig.savefig(target, dpi=dpi, bbox_inches="tight")
        plt.close(fig)
        return target
