#!/bin/sh
# experiments/deadline_strict_lead (README): run.sh OUT, with a worktree of the declaring commit at /work/dsl.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # arm first-seed half [--ctl ...]
  arm=$1; seed=$2; half=$3; shift 3
  PYTHONPATH=/work/dsl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $seed --workers 1 --timeout 900 --latency 0.05:strict "$@" --out $out/$arm/$half
}
arm lead02 0 a --ctl deadline_lead=0.2
arm default 0 a
arm default 12 b
arm lead02 12 b --ctl deadline_lead=0.2
