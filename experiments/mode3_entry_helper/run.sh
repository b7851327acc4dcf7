#!/bin/sh
# ABBA in strict real time at 50 ms (README): run.sh FIRST_SEED OUT_PREFIX, from experiments/mode3_entry_helper.
set -e
UVMS=/work/main/.venv/bin/uvms
first=$1; prefix=$2; second=$((first + 12))
part() {  # arm first-seed name [--ctl ...]
  arm=$1; seed=$2; name=$3; shift 3
  PYTHONPATH=/work/entry $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $seed --workers 1 --timeout 900 --latency 0.05:strict "$@" --out $prefix/$arm/$name
}
part helper $first a --ctl mode3_entry_helper=true
part default $first a
part default $second b
part helper $second b --ctl mode3_entry_helper=true
