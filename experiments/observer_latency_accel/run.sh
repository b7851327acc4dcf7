#!/bin/sh
# experiments/observer_latency_accel (README): run.sh OUT, at the declaring commit.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
# Part 1: fixed 50 ms, wide mismatch, deterministic: the two arms side by side
part1() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios current-steady,current-gust --controllers switching --seeds 30 --first-seed 9340 \
    --workers 1 --timeout 900 --mismatch wide --latency 0.05 "$@" --out $out/part1/$n
}
part1 observed --ctl observe_under_latency=true --ctl observer.learning_acceleration=0.5 & part1 default; wait
# Part 2: strict 50 ms, one run at a time, ABBA
part2() {  # name half first-seed [--ctl ...]
  n=$1; half=$2; first=$3; shift 3
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $first --workers 1 --timeout 900 --latency 0.05:strict "$@" --out $out/part2/$n/$half
}
part2 observed a 9370 --ctl observe_under_latency=true --ctl observer.learning_acceleration=0.5; part2 default a 9370
part2 default b 9382; part2 observed b 9382 --ctl observe_under_latency=true --ctl observer.learning_acceleration=0.5
