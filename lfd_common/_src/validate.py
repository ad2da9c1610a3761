"""Validation of user input at public boundaries (numpy in, outside jitted code).

Each check raises `ValueError` whose message starts with the argument's name and says what was
expected and what was given, so bad input never turns into a silent NaN or an XLA crash.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

ShapeSpec = Sequence[int | str | None]


def _fmt_shape(spec: ShapeSpec) -> str:
    return "(" + ", ".join("?" if s is None else str(s) for s in spec) + (",)" if len(spec) == 1 else ")")


def as_array(
    value: Any,
    name: str,
    *,
    shape: ShapeSpec | None = None,
    ndim: int | Iterable[int] | None = None,
    dtype: Any = np.float64,
    finite: bool = True,
    nonempty: bool = True,
    min_value: float | None = None,
    max_value: float | None = None,
) -> np.ndarray:
    """Convert `value` to a numpy array of `dtype` and check it at a public boundary.

    The keywords state what the argument must look like; the message of every failure starts
    with `name` and says what was expected and what was given.

    Args:
        value: Anything `np.asarray` accepts.
        name: The argument's name, for error messages.
        shape: Expected shape; an int entry must match exactly, a str entry (e.g. "T") or None
            matches any size. A str used twice must have the same size at both places.
        ndim: Allowed number of dimensions (an int or several), when `shape` is not given.
        dtype: Target dtype (None keeps the input's, which must be numeric or bool). Integer
            targets reject non-integral floats.
        finite: Reject NaN and +-inf.
        nonempty: Reject arrays with a zero-sized axis.
        min_value: Inclusive lower bound on every element.
        max_value: Inclusive upper bound on every element.

    Returns:
        The checked numpy array.

    Raises:
        ValueError: Naming `name`: not convertible, ragged or non-numeric, non-integral for an
            integer dtype, wrong shape or ndim, empty, NaN/inf, or out of bounds.
    """
    try:
        raw = np.asarray(value)
    except Exception as err:  # ragged nested lists and the like
        raise ValueError(f"{name}: cannot be converted to an array ({err})") from err
    if raw.dtype == object:
        raise ValueError(f"{name}: expected a numeric array, got a ragged or object array")
    # also with dtype=None: strings, dates or records would fail later in numpy's own ufuncs
    if not (np.issubdtype(raw.dtype, np.number) or raw.dtype == bool):
        raise ValueError(f"{name}: expected a numeric array, got dtype {raw.dtype}")
    if dtype is not None:
        target = np.dtype(dtype)
        if np.issubdtype(target, np.integer) and np.issubdtype(raw.dtype, np.floating):
            if not np.all(np.isfinite(raw)) or not np.all(raw == np.round(raw)):
                raise ValueError(f"{name}: expected integers, got non-integral values")
        arr = raw.astype(target, copy=False)
    else:
        arr = raw
    if shape is not None:
        sizes: dict[str, int] = {}
        ok = arr.ndim == len(shape)
        if ok:
            for want, got in zip(shape, arr.shape):
                if isinstance(want, int) and want != got:
                    ok = False
                elif isinstance(want, str):
                    if sizes.setdefault(want, got) != got:
                        ok = False
        if not ok:
            raise ValueError(f"{name}: expected shape {_fmt_shape(shape)}, got {arr.shape}")
    elif ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            want = " or ".join(str(n) for n in allowed)
            raise ValueError(f"{name}: expected a {want}-D array, got shape {arr.shape}")
    if nonempty and arr.size == 0:
        raise ValueError(f"{name}: must not be empty, got shape {arr.shape}")
    if finite and np.issubdtype(arr.dtype, np.inexact) and not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        raise ValueError(f"{name}: contains {bad} NaN or infinite value(s)")
    if arr.size and min_value is not None and np.min(arr) < min_value:
        raise ValueError(f"{name}: values must be >= {min_value}, got min {np.min(arr)}")
    if arr.size and max_value is not None and np.max(arr) > max_value:
        raise ValueError(f"{name}: values must be <= {max_value}, got max {np.max(arr)}")
    return arr


def check_int(value: Any, name: str, *, min_value: int | None = None, max_value: int | None = None) -> int:
    """Check an integer argument (bool is not an integer here).

    Args:
        value: The argument.
        name: Its name, for error messages.
        min_value: Inclusive lower bound, or None.
        max_value: Inclusive upper bound, or None.

    Returns:
        `value` as an int.

    Raises:
        ValueError: Naming `name`, when it is not an integer within the bounds.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer, got {value!r}")
    value = int(value)
    if min_value is not None and value < min_value:
        raise ValueError(f"{name}: must be >= {min_value}, got {value}")
    if max_value is not None and value > max_value:
        raise ValueError(f"{name}: must be <= {max_value}, got {value}")
    return value


def check_real(
    value: Any,
    name: str,
    *,
    min_value: float | None = None,
    max_value: float | None = None,
    exclusive_min: bool = False,
) -> float:
    """Check a real-number argument: finite and within the bounds.

    Args:
        value: The argument (int or float, numpy scalars included; not bool).
        name: Its name, for error messages.
        min_value: Lower bound, or None.
        max_value: Inclusive upper bound, or None.
        exclusive_min: `min_value` itself is not allowed.

    Returns:
        `value` as a float.

    Raises:
        ValueError: Naming `name`, when it is not a real number, not finite, or out of bounds.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a real number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name}: must be finite, got {value}")
    if min_value is not None and (value <= min_value if exclusive_min else value < min_value):
        raise ValueError(f"{name}: must be {'>' if exclusive_min else '>='} {min_value}, got {value}")
    if max_value is not None and value > max_value:
        raise ValueError(f"{name}: must be <= {max_value}, got {value}")
    return value


def check_choice(value: Any, name: str, choices: Iterable[Any]) -> Any:
    """Check that an argument is one of a few allowed values.

    Args:
        value: The argument.
        name: Its name, for error messages.
        choices: The allowed values.

    Returns:
        `value`.

    Raises:
        ValueError: Naming `name` and listing the choices, when it is none of them.
    """
    choices = tuple(choices)
    if value not in choices:
        raise ValueError(f"{name}: expected one of {choices}, got {value!r}")
    return value
