#!/bin/sh
# experiments/mode3_friction_floor (README): run.sh OUT, at the declaring commit (no latency: deterministic).
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
camp() {  # name mismatch first-seed [--ctl ...]
  n=$1; mm=$2; first=$3; shift 3
  $UVMS campaign --scenarios thrusters-dead --controllers switching --mismatch $mm \
    --seeds 40 --first-seed $first --workers 1 --timeout 900 "$@" --out $out/$n
}
camp wide_mu05 wide 100 & camp wide_mu01 wide 100 --ctl mode3.friction=0.1 & wait
camp default_mu05 default 0 & camp default_mu01 default 0 --ctl mode3.friction=0.1 & wait
$UVMS compare $out/wide_mu05 $out/wide_mu01 > $out/compare_wide.md
$UVMS compare $out/default_mu05 $out/default_mu01 > $out/compare_default.md
