#!/bin/sh
# ABBA: assumed/a, told/a, told/b, assumed/b (README). Run from experiments/realtime_measured_assumed.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/measured MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency measured "$@" --out $arm/$name
}
part assumed 5000 a --ctl assumed_latency=0.05
part told 5000 a
part told 5012 b
part assumed 5012 b --ctl assumed_latency=0.05
