#!/bin/sh
# experiments/deadline_contact_time (README): run.sh PART OUT, with worktrees of the declaring
# commit at /work/dl_new and of its parent at /work/dl_old.
set -e
UVMS=/work/main/.venv/bin/uvms
part=$1; out=$2
arm() {  # arm first-seed name scenarios latency workers
  PYTHONPATH=/work/dl_$1 $UVMS campaign --scenarios $4 --controllers switching --seeds $7 --first-seed $2 \
    --workers $6 --timeout 900 --latency $5 --out $out/$1/$3
}
ALL=wall-headon,wall-oblique,arm-deployed,thrusters-dead
THREE=wall-headon,wall-oblique,arm-deployed
case $part in
  1) arm new 0 none $ALL none 2 12; arm old 0 none $ALL none 2 12 ;;
  2) arm new 8470 fixed $ALL 0.05 2 30; arm old 8470 fixed $ALL 0.05 2 30 ;;
  3) arm new 8500 a $THREE 0.05:strict 1 12; arm old 8500 a $THREE 0.05:strict 1 12
     arm old 8512 b $THREE 0.05:strict 1 12; arm new 8512 b $THREE 0.05:strict 1 12 ;;
esac
