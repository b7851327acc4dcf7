#!/bin/sh
# ABBA: short/a, default/a, default/b, short/b (README). Run from experiments/realtime_mode3_short.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/short MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part short 5000 a --ctl mode3.horizon=3
part default 5000 a
part default 5012 b
part short 5012 b --ctl mode3.horizon=3
