#!/bin/sh
./run.sh && ./run_measured.sh && ./run_nodelay.sh
