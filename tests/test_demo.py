import json

import numpy as np
import pytest

from experiments import demo
from sim.scenes import table_height_m


def test_demo_writes_frame_and_metrics(tmp_path):
    out = tmp_path / "demo"
    metrics = demo.main(["--out", str(out), "--n-worlds", "2", "--n-objects", "2", "--sim-seconds", "0.4",
                         "--image-width", "64", "--image-height", "48", "--stages", "sim"])
    import matplotlib.pyplot as plt

    frame = plt.imread(out / "frame.png")
    assert frame.shape[:2] == (48, 64)
    assert frame[..., :3].std() > 0.01  # a rendered scene, not a blank image
    assert (out / "heights.png").exists() and (out / "report.md").exists()
    saved = json.loads((out / "metrics.json").read_text())
    assert saved["sim_worlds"] == 2 and saved["jax_backend"] == "cpu"
    # Objects fall from 5-40 cm above the table: after 0.4 s they must be lower than they started
    # and must not have fallen through the table (sphere radius / half box size is 3.5-4 cm).
    assert 0.0 < metrics["sim_final_height_above_table_m_min"] < 0.45
    assert metrics["sim_final_height_above_table_m_max"] < 0.45


def test_render_frame_validates_input():
    import mujoco

    import sim

    model = mujoco.MjModel.from_xml_string(sim.tabletop_drop_scene(1))
    with pytest.raises(ValueError, match="qpos: expected shape"):
        sim.render_frame(model, np.zeros(3))
    with pytest.raises(ValueError, match="width"):
        sim.render_frame(model, model.qpos0, width=10_000)
    assert table_height_m() > 0


def test_demo_rejects_unknown_stage(tmp_path):
    with pytest.raises((ValueError, SystemExit)):
        demo.main(["--out", str(tmp_path / "d"), "--stages", "sim,nope"])
