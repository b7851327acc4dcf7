#!/bin/sh
# experiments/certificate_budget (README): run.sh OUT, with a worktree of the declaring commit at /work/cb.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed
  case $1 in budget) ctl="--ctl certificate_budget=0.8";; default) ctl="";; esac
  PYTHONPATH=/work/cb $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $3 --workers 1 --timeout 900 --latency 0.05:strict $ctl --out $out/$1/$2
}
arm budget a 8722; arm default a 8722; arm default b 8734; arm budget b 8734
