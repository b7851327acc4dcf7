#!/bin/sh
# experiments/observer_learning_acceleration (README): run.sh OUT screen|heldout, at the declaring commit.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # part name scenarios seeds first mismatch [--ctl ...]
  p=$1; n=$2; sc=$3; seeds=$4; first=$5; mm=$6; shift 6
  $UVMS campaign --scenarios $sc --controllers switching --seeds $seeds --first-seed $first --workers 1 \
    --timeout 900 --mismatch $mm "$@" --out $out/$p/$n
}
both() {  # part scenarios seeds first mismatch: the two arms side by side
  q=$1; shift
  arm $q default "$@" & arm $q accel "$@" --ctl observer.learning_acceleration=0.5; wait
}
if [ "$2" = screen ]; then
  both walls wall-headon,wall-oblique,arm-deployed 24 0 default
  both station current-steady,current-gust 30 0 wide
  both thrusters thrusters-dead 12 100 wide
else
  both heldout_walls wall-headon,wall-oblique,arm-deployed 30 9340 default
  both heldout_station current-steady,current-gust 30 9340 wide
fi
