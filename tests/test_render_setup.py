"""`import sim` has no side effect; `sim.setup_rendering` makes offscreen rendering work whenever it is
called (each case in a fresh interpreter: MuJoCo reads MUJOCO_GL once per process)."""
import os
import subprocess
import sys
import textwrap

import pytest

_SCENE = ('<mujoco><visual><global offwidth="64" offheight="64"/></visual><worldbody><light pos="0 0 1"/>'
          '<camera name="c" pos="0 0 1"/><body><freejoint/><geom type="sphere" size=".2" rgba="1 0 0 1"/></body>'
          '</worldbody></mujoco>')


def _run(code: str, **env) -> str:
    clean = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                         env={**clean, **env}, timeout=300, cwd=os.path.dirname(os.path.dirname(__file__)))
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout.strip().splitlines()[-1]


def test_import_sim_leaves_mujoco_gl_alone():
    assert _run("import sim, os; print(os.environ.get('MUJOCO_GL'))") == "None"


def test_setup_after_mujoco_was_imported_without_a_backend_renders():
    """mujoco (via sim) imported with MUJOCO_GL unset picked GLFW; setup_rendering switches the
    renderer to EGL and a plain `mujoco.Renderer` then draws the red sphere."""
    line = _run(f"""
        import os, mujoco, sim
        assert "MUJOCO_GL" not in os.environ
        print(sim.setup_rendering(), sim.setup_rendering())  # idempotent
        m = mujoco.MjModel.from_xml_string('{_SCENE}')
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        with mujoco.Renderer(m, 64, 64) as r:
            r.update_scene(d, camera="c")
            img = r.render()
        from mujoco.rendering.classic import gl_context  # where mujoco.Renderer looks the class up
        print(os.environ["MUJOCO_GL"], gl_context.GLContext.__module__, int(img[32, 32, 0]), int(img[32, 32, 1]))
    """)
    backend, module, red, green = line.split()
    assert (backend, module) == ("egl", "mujoco.egl")
    assert int(red) > 200 and int(green) < int(red) - 100  # the red sphere, not a blank image


def test_render_frame_works_without_setup_and_env_wins():
    line = _run(f"""
        import os, mujoco, sim
        m = mujoco.MjModel.from_xml_string('{_SCENE}')
        img = sim.render_frame(m, m.qpos0, 64, 64, camera="c")
        print(os.environ["MUJOCO_GL"], sim.setup_rendering("osmesa"), int(img[32, 32, 0]))
    """)
    assert line.split()[:2] == ["egl", "egl"]  # the first choice (made by render_frame) stays
    assert int(line.split()[2]) > 100


def test_setup_rendering_rejects_unknown_backend():
    import sim

    with pytest.raises(ValueError, match="backend"):
        sim.setup_rendering("vulkan")
