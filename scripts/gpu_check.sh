#!/usr/bin/env bash
# The checks and benchmarks to run on a machine with a GPU (a CUDA build of JAX installed,
# with equinox, optimistix, jaxtyping, numpy, matplotlib, tqdm, pytest and pytest-xdist),
# from the repository's root, vojax not installed:
#
#     OUT=results-folder bash scripts/gpu_check.sh
#
# 1. the kernels', the tracker's and the law's tests on the GPU (float64 there too);
# 2. the tracker's filter and smoother, sequential against parallel-in-time schedules;
# 3. the first call and the cost per sample up to 1e6 samples (bench_first_call).
# Each part has its own time limit, and writes its log to $OUT as it goes.
set -u
OUT=${OUT:-gpu-results}
mkdir -p "$OUT" && OUT=$(cd "$OUT" && pwd)
export PYTHONPATH=$PWD PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_PREALLOCATE=false
PY=${PYTHON:-python3}
{
  date -u
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  "$PY" -c "import jax, equinox, optimistix; print('jax', jax.__version__, jax.devices(), 'equinox', equinox.__version__, 'optimistix', optimistix.__version__)"
} 2>&1 | tee "$OUT/env.txt"
# a part whose time limit is set to 0 is skipped
[ "${TESTS_S:-170}" = 0 ] || timeout "${TESTS_S:-170}" bash -c '
  flags="-q -p no:cacheprovider -p no:benchmark"
  "$0" -m pytest $flags -n 4 tests/test_parallel.py tests/test_kernels.py tests/test_tracker.py \
    tests/test_blocks.py tests/test_coloured.py
  "$0" -m pytest $flags -n 2 -m slow tests/test_parallel.py' "$PY" 2>&1 | tee "$OUT/tests.txt"
[ "${SMOOTHER_S:-150}" = 0 ] || (cd scripts && timeout "${SMOOTHER_S:-150}" "$PY" \
  bench_parallel_smoother.py --loops default --cases alone 1000 \
  --out "$OUT/bench_parallel_smoother.txt") 2>&1 | tee "$OUT/bench_parallel_smoother.log"
[ "${FIRST_S:-240}" = 0 ] || (cd scripts && timeout "${FIRST_S:-240}" "$PY" bench_first_call.py \
  --loops default --lengths 1000 100000 1000000 --law-max 100000 \
  --out "$OUT/bench_first_call.txt") 2>&1 | tee "$OUT/bench_first_call.log"
