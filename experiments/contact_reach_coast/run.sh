#!/bin/sh
# experiments/contact_reach_coast (README): run.sh PART OUT, with a worktree of the declaring commit
# at /work/rc. Arms: `reach` the default, `noreach` the same code with contact_reach=false.
set -e
PY=/work/main/.venv/bin/python
UVMS=/work/main/.venv/bin/uvms
part=$1; out=$2
arm() {  # arm first-seed name scenarios latency workers seeds
  case $1 in reach) ctl="";; noreach) ctl="--ctl contact_reach=false";; esac
  PYTHONPATH=/work/rc $UVMS campaign --scenarios $4 --controllers switching --seeds $7 --first-seed $2 \
    --workers $6 --timeout 900 --latency $5 $ctl --out $out/$1/$3
}
THREE=wall-headon,wall-oblique,arm-deployed
case $part in
  1) mkdir -p $out/reach $out/noreach && cd /work/rc
     PYTHONPATH=/work/rc $PY experiments/handover_coast/entries_late.py $out/reach/entries_late.csv 8650 24
     PYTHONPATH=/work/rc $PY experiments/handover_coast/entries_late.py $out/noreach/entries_late.csv 8650 24 \
       contact_reach=false ;;
  2) arm reach 8674 a $THREE 0.05:strict 1 12; arm noreach 8674 a $THREE 0.05:strict 1 12
     arm noreach 8686 b $THREE 0.05:strict 1 12; arm reach 8686 b $THREE 0.05:strict 1 12 ;;
esac
