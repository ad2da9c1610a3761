#!/usr/bin/env bash
# The benchmarks in one call on the device machine (NVIDIA H200; README "Benchmarks", "On an NVIDIA
# H200"). Run from the repository root with `.whl` (the anchors' and MuJoCo's wheels, cp312 x86-64),
# `.gl` (the EGL loader .debs) and `.benchdata` (CDnet highway frames 1-620, the first 24 HGR photos)
# carried; every bench's folder is tarred into $OUT/bench_runs.tgz after each bench, the whole output
# goes to $OUT/gpu_run.log.
#
#   bash experiments/bench/gpu_run.sh                      # on the device machine
#   GPU_RUN_LOCAL=1 PY=.venv/bin/python BENCHES="lsh" bash experiments/bench/gpu_run.sh   # a dry run here
#
# Each bench runs under its own `timeout`, so that one hang does not lose the rest.
set -u
OUT=${OUT:-/tmp/gpu_run_out}
mkdir -p "$OUT"
LOG=$OUT/gpu_run.log
exec > >(tee -a "$LOG") 2>&1
RUNS=/tmp/gpu_runs
rm -rf "$RUNS"; mkdir -p "$RUNS"
T0=$(date +%s)
stamp() { echo "[$(date -u +%H:%M:%S) +$(( $(date +%s) - T0 ))s] $*"; }

export PYTHONUNBUFFERED=1 MUJOCO_GL=egl XLA_PYTHON_CLIENT_PREALLOCATE=false
export LFD_JAX_CACHE=${LFD_JAX_CACHE:-/tmp/lfdcache}
PY=${PY:-python3}
stamp "start; commit $(git rev-parse --short HEAD 2>/dev/null || echo '?')"

if [ -z "${GPU_RUN_LOCAL:-}" ]; then
  # EGL loaders (device README), then the wheels into /tmp/site
  if [ -d .gl ]; then for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig; fi
  $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl \
    || { stamp "pip install failed"; exit 3; }
  # dynamax imports fastprogress (whose own import pulls in python-fasthtml and its web stack) for the
  # progress bars of fit_em / fit_sgd only, which the benches never call: a stub stands in for it
  mkdir -p /tmp/stub/fastprogress
  printf 'def progress_bar(it, *a, **k):\n    return it\n' > /tmp/stub/fastprogress/fastprogress.py
  printf 'from .fastprogress import progress_bar\n' > /tmp/stub/fastprogress/__init__.py
  export PYTHONPATH=/tmp/site:/tmp/stub:$PWD
  nvidia-smi || true
else
  export PYTHONPATH=$PWD
fi
stamp "installed"
$PY - <<'EOF'
import importlib, os, platform
print("python", platform.python_version(), "cpus", os.cpu_count())
import jax
print("jax", jax.__version__, jax.devices())
for name in ["jaxlib", "numpy", "cv2", "skimage", "faiss", "hmmlearn", "dynamax", "pycrfsuite", "sklearn_crfsuite",
             "mujoco", "mujoco.mjx", "OpenGL", "trimesh", "tensorflow_probability.substrates.jax"]:
    try:
        m = importlib.import_module(name)
        print(f"  {name} {getattr(m, '__version__', '')}")
    except Exception as err:  # report every missing piece at once
        print(f"  {name} FAILED: {type(err).__name__}: {err}")
EOF
stamp "imports checked"

# MuJoCo's EGL context (rendering for bench_object_segmentation); without it MUJOCO_GL=disable, so that
# the benches that only step physics still import MuJoCo
if ! $PY -c 'import mujoco; c = mujoco.GLContext(64, 64); c.make_current(); c.free(); print("EGL context: ok")'; then
  stamp "EGL context failed: MUJOCO_GL=disable (bench_object_segmentation will fail)"; export MUJOCO_GL=disable
fi

# preset, time limit (s), extra flags and module per entry, in the order run: the GPU kernels first,
# MJX (its compilation alone took 74 s on the 2-core CPU) before the cheap rest, then, only when at
# least 110 s are left, LSH at N = 100,000 (its 101,500 procedural hands take about a minute to draw on
# one core). Every limit is cut to what is left of TOTAL seconds from the start.
TOTAL=${TOTAL:-490}
ALL="hmm lsh hog mjx object_segmentation levelset crf background lsh100k"
BENCHES=${BENCHES:-$ALL}
declare -A PRESET=([hmm]=paper [lsh]=quick [hog]=paper [mjx]=quick [object_segmentation]=paper [levelset]=quick
                   [crf]=quick [background]=quick [lsh100k]=quick)
declare -A LIMIT=([hmm]=130 [lsh]=40 [hog]=70 [mjx]=170 [object_segmentation]=60 [levelset]=30 [crf]=30
                  [background]=40 [lsh100k]=150)
declare -A MINIMUM=([lsh100k]=110)
declare -A MODULE=([lsh100k]=lsh)
# hmmlearn on 8 sequences (its per-sequence cost is flat in the batch; 56 took 145 s here); HOG: one
# timed call after the warm-up (scikit-image's loop over 5,400 images is single-threaded)
declare -A EXTRA=([hmm]="--hmmlearn-batch 8" [hog]="--repeats 1" [mjx]="--mjx-trials ${MJX_TRIALS:-1024}"
                  [levelset]="--data-dir .benchdata/hgr_hands" [background]="--cdnet-dir .benchdata/cdnet_highway"
                  [lsh100k]="--sizes 100000")
for kv in ${LIMITS:-}; do LIMIT[${kv%%=*}]=${kv#*=}; done  # e.g. LIMITS="hmm=140 mjx=230"
for b in $BENCHES; do
  p=${PRESET[$b]}; extra=${EXTRA[$b]:-}; mod=${MODULE[$b]:-$b}
  left=$(( TOTAL - ($(date +%s) - T0) )); lim=${LIMIT[$b]}; [ "$left" -lt "$lim" ] && lim=$left
  if [ "$lim" -lt "${MINIMUM[$b]:-10}" ]; then stamp "bench_$b skipped: ${left}s left of ${TOTAL}s"; continue; fi
  stamp "bench_$mod ($b) --preset $p $extra (timeout ${lim}s)"
  timeout -k 5 "$lim" $PY -m experiments.bench.bench_$mod --preset "$p" --out "$RUNS/$b" $extra 2>&1 \
    | tee "$RUNS/$b.log"
  rc=${PIPESTATUS[0]}
  stamp "bench_$b rc=$rc$([ "$rc" = 124 ] && echo ' (timed out)')"
  (cd /tmp && tar czf "$OUT/bench_runs.tgz" --exclude='*.png' --exclude='*.mp4' --exclude='*.gif' gpu_runs)
done
nvidia-smi --query-gpu=name,memory.used,memory.total --format=csv 2>/dev/null || true
stamp "done"
sleep 1  # let tee finish the log
