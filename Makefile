# Two commands for a newcomer: `make demo` and `make test`. Each creates .venv (python3 -m venv) and
# installs the package with its extras once; the stamp is keyed on the content of pyproject.toml, so a
# second run does not reinstall, and an edited pyproject.toml does.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell sha1sum pyproject.toml | cut -c1-12)
# Two workers, whole test files each (the suite is compile-bound: one XLA compile per worker at a time,
# so two workers on two cores take about 60 % of the serial time). The pytest processes use no
# persistent compilation cache (tests/conftest.py says why); data caches are written atomically.
# A crashed worker ends the run (no restart): a replaced worker can leave pytest-xdist waiting forever.
# --no-loadscope-reorder keeps the collection order, which tests/conftest.py sets heaviest files first
# (xdist's default order, most tests per file first, left the minute-long one-test files for the end).
PYTEST_ARGS ?= -n 2 --dist loadfile --no-loadscope-reorder --max-worker-restart=0
DEMO_ARGS ?= --preset quick
BENCH_ARGS ?= --preset quick

.PHONY: demo test bench install clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test,bench,mocap,docs]'
	rm -f $(VENV)/.installed-*
	touch $@

demo: $(STAMP)
	$(PY) -m experiments.demo $(DEMO_ARGS)

# The project's own modules byte-compiled first (under a second): where PYTHONDONTWRITEBYTECODE is set,
# nothing writes them, and each of the suite's Python processes (two workers and some 30 subprocesses)
# compiled every module it imported from source, about 1.5 s of each start and 5 s of each worker's
# collection. A stale .pyc is never used (Python checks the source's size and time).
SOURCES := lfd_common phmm_jax hog_jax crf_jax sim lfd_jax experiments tests

test: $(STAMP)
	$(PY) -m compileall -q $(SOURCES)
	$(PY) -m pytest $(PYTEST_ARGS)

bench: $(STAMP)
	@set -e; for f in experiments/bench/bench_*.py; do \
		[ -e "$$f" ] || { echo "no benchmarks yet"; break; }; \
		m=$$(echo "$$f" | sed 's#/#.#g; s#\.py$$##'); \
		echo "== $$m"; $(PY) -m "$$m" $(BENCH_ARGS); \
	done

# `make peers`: a second environment, .venv-peers, for the peers whose pins clash with ours (MediaPipe
# Hands), so that one process can time ours, OpenCV and MediaPipe side by side
# (experiments/bench/bench_video_realtime.py). MediaPipe 0.10.21 is the last release whose wheel carries
# the legacy `mediapipe.solutions.hands` graph with its palm-detection and hand-landmark .tflite models
# (0.10.30 on ship neither; their Tasks API downloads a .task file at run time). It declares numpy<2 and
# opencv-contrib-python; it is installed without its dependencies on top of ours (numpy 2, the same
# opencv-python-headless, whose cv2 has MOG2 and KNN), every version pinned to the one in .venv.
PEERS_VENV := .venv-peers
PEERS_PY := $(PEERS_VENV)/bin/python
MEDIAPIPE_VERSION ?= 0.10.21
PEERS_STAMP := $(PEERS_VENV)/.installed-$(shell cat pyproject.toml Makefile | sha1sum | cut -c1-12)

.PHONY: peers
peers: $(PEERS_STAMP)

$(PEERS_STAMP): pyproject.toml Makefile
	test -x $(PY) || $(MAKE) install
	test -x $(PEERS_PY) || $(PYTHON) -m venv $(PEERS_VENV)
	$(PEERS_PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip freeze --exclude-editable | grep -v -i '^mediapipe' > $(PEERS_VENV)/constraints.txt
	$(PEERS_PY) -m pip install --quiet -c $(PEERS_VENV)/constraints.txt -e . absl-py attrs flatbuffers 'protobuf>=4.25.3,<5'
	$(PEERS_PY) -m pip install --quiet --no-deps mediapipe==$(MEDIAPIPE_VERSION)
	$(PEERS_PY) -c "import mediapipe as mp; mp.solutions.hands.Hands(static_image_mode=True).close(); print('mediapipe', mp.__version__, 'hands ok')"
	rm -f $(PEERS_VENV)/.installed-*
	touch $@

# The documentation site (MkDocs, Material theme, API reference from the docstrings) into site/;
# --strict turns every warning into an error.
.PHONY: docs results
docs: $(STAMP)
	$(PY) -m mkdocs build --strict --site-dir site

# docs/results.md, docs/benchmarks.md and README's results table, generated from the run folders
# under RUNS (each study's metrics.json / bench.json, config.json, run.json, report.md).
RUNS ?= runs
results: $(STAMP)
	$(PY) -m experiments.site_results $(RUNS)

clean:
	rm -rf $(VENV) runs .pytest_cache
