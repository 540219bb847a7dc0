#!/usr/bin/env bash
# One device session: the calibration suite's held-out draws on the CPU cores (JAX on the
# CPU, one thread a record) beside the GPU checks of gpu_check.sh. Inputs: ./shared/data.
set -u
OUT=${OUT:-device-results}
mkdir -p "$OUT" && OUT=$(cd "$OUT" && pwd)
export PYTHONPATH=$PWD PYTHONUNBUFFERED=1
( JAX_PLATFORMS=cpu timeout "${CALIB_S:-330}" python3 scripts/bench_calibration.py \
    --first 12 --per-family 12 --workers "${WORKERS:-11}" --threads 1 --data shared/data \
    --methods tracker tracker-constant tracker-x0 tracker-constant-x0 tracker-stated \
    --note "run on the device machine's CPU cores (JAX_PLATFORMS=cpu)" \
    --out "$OUT/bench_calibration_held_out.txt" > "$OUT/calibration.log" 2>&1 ) &
calib=$!
OUT=$OUT TESTS_S=${TESTS_S:-170} SMOOTHER_S=0 FIRST_S=${FIRST_S:-150} bash scripts/gpu_check.sh
wait $calib
tail -40 "$OUT/calibration.log"
