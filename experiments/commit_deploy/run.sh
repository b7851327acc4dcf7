#!/bin/sh
# Part 1, ABBA: commit/a, default/a, default/b, commit/b (README). Run from experiments/commit_deploy.
# Part 2 (only if part 1 is undecided): the same on seeds 8254-8277 (commit2/, default2/), with `sh run.sh 2`.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/commitdeploy MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
if [ "$1" = 2 ]; then
  part commit2 8254 a --ctl commit_deploy=true
  part default2 8254 a
  part default2 8266 b
  part commit2 8266 b --ctl commit_deploy=true
else
  part commit 8230 a --ctl commit_deploy=true
  part default 8230 a
  part default 8242 b
  part commit 8242 b --ctl commit_deploy=true
fi
