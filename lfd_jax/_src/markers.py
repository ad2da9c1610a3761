"""The one in-memory format of marker data, and what is done to it before a model sees it: gap
filling over short gaps, choosing markers, resampling to a fixed number of frames.

`MarkerRecording(markers (T, M, 3) float64 metres, names (M,), rate_hz)` is what every marker loader
returns (`marker_files.load_markers`) and what the PHMM code takes once it is finite:
`recording.markers.reshape(T, -1)` is a (T, 3 M) feature sequence, the layout of
`experiments.data.tabletop.resample`. Gaps (occluded or unlabelled samples) are NaN.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from lfd_common import as_array, check_int, check_real


class MarkerRecording(NamedTuple):
    """Marker data in the one in-memory format every marker reader returns.

    Attributes:
        markers: (T, M, 3) float64 positions in metres, NaN in gaps.
        names: (M,) marker labels (without a Vicon "subject:" prefix).
        rate_hz: the frame rate.
    """

    markers: np.ndarray
    names: tuple[str, ...]
    rate_hz: float


def make_recording(markers, names: Sequence[str], rate_hz: float) -> MarkerRecording:
    """A checked `MarkerRecording`.

    Args:
        markers: (T, M, 3) real positions in metres (NaN allowed for gaps, ±inf not).
        names: one unique name per marker.
        rate_hz: the frame rate, positive and finite.

    Returns:
        The `MarkerRecording` (markers as float64).

    Raises:
        ValueError: naming the argument that breaks one of the above.
    """
    arr = as_array(markers, "markers", shape=(None, None, 3), finite=False)
    if np.isinf(arr).any():
        raise ValueError("markers: contains infinite values (gaps must be NaN)")
    names = tuple(str(n) for n in names)
    if len(names) != arr.shape[1]:
        raise ValueError(f"names: expected {arr.shape[1]} names (one per marker), got {len(names)}")
    if len(set(names)) != len(names):
        raise ValueError(f"names: marker names must be unique, got duplicates "
                         f"{sorted({n for n in names if names.count(n) > 1})}")
    return MarkerRecording(arr, names, check_real(rate_hz, "rate_hz", min_value=0.0, exclusive_min=True))


def _check_recording(recording) -> MarkerRecording:
    if not isinstance(recording, MarkerRecording):
        raise ValueError(f"recording: expected a MarkerRecording, got {type(recording).__name__}")
    return recording


def gap_runs(missing: np.ndarray) -> list[tuple[int, int]]:
    """The runs of True in a 1-D bool array.

    Args:
        missing: (T,) bool, True where a frame is missing.

    Returns:
        The runs as (first, last) frame indices, inclusive, in order.
    """
    padded = np.concatenate([[False], np.asarray(missing, bool), [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]


def fill_gaps(recording: MarkerRecording, max_gap_s: float = 0.2, *, max_gap_frames: int | None = None
              ) -> MarkerRecording:
    """Short gaps filled by linear interpolation in time, per marker and coordinate.

    Interpolation is `numpy.interp` between the last frame before and the first frame after the gap; a
    gap at the start or the end takes the nearest seen value. A frame is a gap for a marker when any
    of its coordinates is NaN.

    Args:
        recording: the `MarkerRecording`.
        max_gap_s: the longest gap filled, in seconds at the recording's rate (rounded down to frames).
        max_gap_frames: the longest gap filled, in frames (overrides `max_gap_s`).

    Returns:
        The recording with its gaps filled.

    Raises:
        ValueError: naming the marker and its frames (0-based, inclusive) for a longer gap, and naming
            a marker that is never seen, whatever the limit (drop it first with
            `drop_untracked_markers`).
    """
    recording = _check_recording(recording)
    if max_gap_frames is None:
        max_gap_frames = int(np.floor(check_real(max_gap_s, "max_gap_s", min_value=0.0) * recording.rate_hz))
    limit = check_int(max_gap_frames, "max_gap_frames", min_value=0)
    markers = recording.markers.copy()
    t = np.arange(len(markers))
    missing = np.isnan(markers).any(axis=-1)  # (T, M)
    for m in np.flatnonzero(missing.any(axis=0)):
        if missing[:, m].all():  # no frame to interpolate from, however long the limit
            raise ValueError(f"recording: marker {recording.names[m]!r} is never seen (all {len(markers)} frames "
                             f"are gaps); drop it first with drop_untracked_markers")
        long = [(a, b) for a, b in gap_runs(missing[:, m]) if b - a + 1 > limit]
        if long:
            shown = ", ".join(f"{a}-{b}" for a, b in long[:5]) + (" ..." if len(long) > 5 else "")
            raise ValueError(f"recording: marker {recording.names[m]!r} has a gap longer than {limit} frames "
                             f"(frames {shown} of {len(markers)}); raise max_gap_frames / max_gap_s or drop it")
        seen = ~missing[:, m]
        for k in range(3):
            markers[:, m, k] = np.interp(t, t[seen], markers[seen, m, k])
    return recording._replace(markers=markers)


def chosen_indices(names: Sequence[str], available: Sequence[str], item: str, holder: str) -> list[int]:
    """The positions of `names` in `available`, each name chosen once.

    Args:
        names: the chosen names, in the order wanted.
        available: the names there are.
        item: what a name names ("marker", "keypoint"), for the messages.
        holder: what holds them ("recording", "tracks"), for the messages.

    Returns:
        The index in `available` of each name of `names`.

    Raises:
        ValueError: naming `names` when it is empty or a string, names one the `holder` lacks, or names
            one twice.
    """
    if isinstance(names, str) or not len(names):
        raise ValueError(f"names: expected a non-empty sequence of {item} names, got {names!r}")
    absent = [n for n in names if n not in available]
    if absent:
        raise ValueError(f"names: no {item}(s) {absent} in the {holder}, whose {item}s are {list(available)}")
    twice = [n for n in dict.fromkeys(names) if list(names).count(n) > 1]
    if twice:
        raise ValueError(f"names: each {item} may be chosen once, got {', '.join(map(repr, twice))} more than once")
    return [list(available).index(n) for n in names]


def select_markers(recording: MarkerRecording, names: Sequence[str]) -> MarkerRecording:
    """Some of the markers, in a given order.

    Args:
        recording: the `MarkerRecording`.
        names: the markers to keep, in the order wanted.

    Returns:
        The recording with those markers only.

    Raises:
        ValueError: naming the markers the recording lacks, a marker named twice, or for an empty
            `names`.
    """
    recording = _check_recording(recording)
    index = chosen_indices(names, recording.names, "marker", "recording")
    return recording._replace(markers=recording.markers[:, index], names=tuple(names))


def drop_untracked_markers(recording: MarkerRecording) -> MarkerRecording:
    """The recording without the markers that have no seen frame (a calibration landmark, say).

    Args:
        recording: the `MarkerRecording`.

    Returns:
        The recording with the markers seen at least once.

    Raises:
        ValueError: when no marker is left.
    """
    recording = _check_recording(recording)
    seen = ~np.isnan(recording.markers).any(axis=-1).all(axis=0)
    if not seen.any():
        raise ValueError("recording: no marker has a seen frame")
    return recording._replace(markers=recording.markers[:, seen],
                              names=tuple(n for n, s in zip(recording.names, seen) if s))


def resample_frames(x, n_frames: int, name: str = "x") -> np.ndarray:
    """An array resampled in time by linear interpolation from its first to its last frame.

    The PHMM papers' "sequences normalised to 100 samples" (Herzog et al. 2008, §IV).

    Args:
        x: (T, ...) values with a leading time axis; NaN stays NaN where it is interpolated.
        n_frames: the number of frames wanted, at least 2.
        name: the argument's name in error messages.

    Returns:
        (n_frames, ...) float array.

    Raises:
        ValueError: naming `name` for a scalar, or `n_frames` below 2.
    """
    arr = as_array(x, name, finite=False)
    if arr.ndim < 1:
        raise ValueError(f"{name}: expected an array with a leading time axis, got a scalar")
    n_frames = check_int(n_frames, "n_frames", min_value=2)
    if len(arr) == 1:
        return np.repeat(arr, n_frames, axis=0)
    pos = np.linspace(0.0, len(arr) - 1, n_frames)
    lo = np.minimum(np.floor(pos).astype(int), len(arr) - 2)
    frac = (pos - lo).reshape(-1, *([1] * (arr.ndim - 1)))
    return (1.0 - frac) * arr[lo] + frac * arr[lo + 1]


def resample(recording: MarkerRecording, n_frames: int) -> MarkerRecording:
    """The recording linearly resampled to a number of frames over the same time span.

    Args:
        recording: the `MarkerRecording`.
        n_frames: the number of frames wanted, at least 2.

    Returns:
        The resampled recording (`resample_frames`); `rate_hz` becomes the rate of the new frames.

    Raises:
        ValueError: naming the argument for a bad recording or `n_frames`.
    """
    recording = _check_recording(recording)
    markers = resample_frames(recording.markers, n_frames, "recording.markers")
    span_s = (len(recording.markers) - 1) / recording.rate_hz
    rate = (n_frames - 1) / span_s if span_s > 0 else recording.rate_hz
    return recording._replace(markers=markers, rate_hz=float(rate))
