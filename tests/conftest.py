import os

os.environ.setdefault("LFD_NO_PROGRESS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")

from lfd_common import enable_compilation_cache  # noqa: E402

enable_compilation_cache()


def pytest_configure(config):
    config.addinivalue_line("markers", "slow_mjx: compiles a full MJX-JAX rollout (minutes cold); "
                                       "runs only with LFD_SLOW_MJX=1")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("LFD_SLOW_MJX") == "1":
        return
    import pytest

    skip = pytest.mark.skip(reason="MJX-JAX rollout compile takes minutes on CPU; set LFD_SLOW_MJX=1")
    for item in items:
        if "slow_mjx" in item.keywords:
            item.add_marker(skip)
