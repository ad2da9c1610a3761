import json

import numpy as np
import pytest

from experiments import demo
from sim.scenes import random_drop_heights, table_height_m


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
    # Each object starts 4 cm + U[5, 40] cm above the table, drawn as the stage draws them (its seed,
    # `random_drop_heights`); 0.4 s is enough to land from 44 cm, where it rests 3.5-4 cm up (sphere
    # radius / half box size). The highest final height below the lowest start minus 3 cm means every
    # object fell at least 3 cm below its own start; objects that never moved would fail it.
    start = 0.04 + random_drop_heights(np.random.default_rng(demo.DemoConfig().seed), 2, 2)
    assert metrics["sim_final_height_above_table_m_max"] < start.min() - 0.03
    assert 0.0 < metrics["sim_final_height_above_table_m_min"]  # not through the table


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
