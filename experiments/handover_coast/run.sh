#!/bin/sh
# experiments/handover_coast (README): run.sh PART OUT, with a worktree of the declaring commit at
# /work/hc. Arms: `coast` the default, `torque` the same code with handover_coast=false.
set -e
PY=/work/main/.venv/bin/python
UVMS=/work/main/.venv/bin/uvms
part=$1; out=$2
arm() {  # arm first-seed name scenarios latency workers seeds
  case $1 in coast) ctl="";; torque) ctl="--ctl handover_coast=false";; esac
  PYTHONPATH=/work/hc $UVMS campaign --scenarios $4 --controllers switching --seeds $7 --first-seed $2 \
    --workers $6 --timeout 900 --latency $5 $ctl --out $out/$1/$3
}
THREE=wall-headon,wall-oblique,arm-deployed
case $part in
  1) mkdir -p $out/coast $out/torque
     cd /work/hc && PYTHONPATH=/work/hc $PY experiments/handover_coast/entries_late.py $out/coast/entries_late.csv 8602 24
     cd /work/hc && PYTHONPATH=/work/hc $PY experiments/handover_coast/entries_late.py $out/torque/entries_late.csv 8602 24 \
       handover_coast=false ;;
  2) arm coast 8578 a $THREE 0.05:strict 1 12; arm torque 8578 a $THREE 0.05:strict 1 12
     arm torque 8590 b $THREE 0.05:strict 1 12; arm coast 8590 b $THREE 0.05:strict 1 12 ;;
esac
