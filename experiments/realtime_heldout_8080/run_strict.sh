#!/bin/sh
# strict/a, strict/b, then none (README's second part). Run from experiments/realtime_heldout_8080.
set -e
UVMS=/work/main/.venv/bin/uvms
run() { PYTHONPATH=/work/heldout MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
  --controllers switching "$@"; }
run --seeds 12 --first-seed 8080 --workers 1 --timeout 900 --latency 0.05:strict --out strict/a
run --seeds 12 --first-seed 8092 --workers 1 --timeout 900 --latency 0.05:strict --out strict/b
run --seeds 24 --first-seed 8080 --workers 2 --timeout 900 --out none
