import os

os.environ.setdefault("LFD_NO_PROGRESS", "1")

from lfd_common import enable_compilation_cache  # noqa: E402

enable_compilation_cache()
