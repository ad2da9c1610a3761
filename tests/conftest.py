import os

os.environ.setdefault("LFD_NO_PROGRESS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")

from lfd_common import enable_compilation_cache  # noqa: E402

enable_compilation_cache()
