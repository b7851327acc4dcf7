#!/bin/sh
# The statics of two sets of wide thrusters-dead draws, and the default's closed loop on the held-out set.
set -e
cd "$(dirname "$0")/../.."
PYTHONPATH=. python experiments/seafloor_statics/statics.py --seeds 8368-8397 --out experiments/seafloor_statics/wide_8368.csv
PYTHONPATH=. python experiments/seafloor_statics/statics.py --seeds 100-139 --out experiments/seafloor_statics/wide_dev_100.csv
uvms campaign --scenarios thrusters-dead --controllers switching --seeds 30 --first-seed 8368 --mismatch wide \
  --workers 2 --timeout 900 --out experiments/seafloor_statics/closed_loop_8368
uvms campaign --scenarios thrusters-dead --controllers switching --seeds 40 --first-seed 100 --mismatch wide \
  --workers 2 --timeout 900 --out experiments/seafloor_statics/closed_loop_dev_100
