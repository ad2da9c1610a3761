"""Render one long recording of a preset and write its pictures:

    python -m experiments.data.video --preset quick --out runs/video

writes contact_sheet.png (frames with the label overlay), recording.mp4 (or .gif) of the left view
with the overlay, and metrics.json with the render speed (frames/s, both views with labels).
"""
from __future__ import annotations

import time

import numpy as np

from experiments.config import parse_config, progress
from experiments.data.video.outputs import contact_sheet
from lfd_jax import overlay, write_video
from experiments.data.video.render import long_scripts, render_recording
from experiments.data.video.settings import ACTIONS, OBJECTS, PRESETS, VideoSettings


def _caption(rec, t: int) -> str:
    act = ACTIONS[rec.action[t]] if rec.action[t] >= 0 else "-"
    obj = f" {OBJECTS[rec.object[t]]}" if rec.object[t] >= 0 else ""
    return f"{t}: {act}{obj}"


def main(argv=None):
    settings, run = parse_config(VideoSettings, PRESETS, name="data.video", argv=argv)
    script = long_scripts(settings)[0] if settings.n_scripts else None
    if script is None:
        raise SystemExit("n_scripts: must be at least 1 to render a recording")
    start = time.perf_counter()
    rec = render_recording(settings, script, cache=False, progress=progress)
    seconds = time.perf_counter() - start
    n = len(rec.action)
    picks = np.unique(np.concatenate([np.linspace(0, n - 1, 18).astype(int), rec.pickup_frames, rec.putdown_frames]))
    picks = picks[np.linspace(0, len(picks) - 1, min(len(picks), 24)).astype(int)]
    contact_sheet(rec.left[picks], rec.left_labels[picks], run.file("contact_sheet.png"),
                  titles=[_caption(rec, int(t)) for t in picks])
    video = write_video(overlay(rec.left, rec.left_labels, alpha=0.35), run.file("recording.mp4"), rec.fps)
    metrics = {"frames": n, "render_s": seconds, "render_fps": n / seconds, "width": settings.width,
               "height": settings.height, "n_pickups": len(rec.pickup_frames), "video": video.name}
    run.write(metrics)
    print(f"{n} frames of {settings.width} x {settings.height} (both views with labels) in {seconds:.1f} s: "
          f"{n / seconds:.1f} frames/s; written to {run.path}")


if __name__ == "__main__":
    main()
