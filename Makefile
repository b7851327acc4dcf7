# Two commands do all the set-up on a fresh machine (python3 with venv, no GPU, no display):
#   make demo   -- create .venv if missing, run wall-headon in closed loop against MuJoCo into out/
#   make test   -- create .venv if missing, run ruff and the whole test suite
#   make bench  -- the benchmarks, into bench/results/ (needs the bench extra: do-mpc)
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
export MUJOCO_GL ?= egl
export PYOPENGL_PLATFORM ?= egl

.PHONY: demo test bench assets clean

$(VENV)/.installed: pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

demo: $(VENV)/.installed
	$(VENV)/bin/uvms run wall-headon --seed 0 --video out/wall-headon.mp4 --record out/wall-headon.rrd --plots out/plots --out out

test: $(VENV)/.installed
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q

bench: $(VENV)/.installed
	$(PY) -m pip install --quiet -e '.[test,bench]'
	$(PY) bench/plant_speed.py
	$(PY) bench/model_eval.py
	$(PY) bench/nmpc_modes.py
	$(PY) bench/closed_loop_rtf.py
	$(PY) bench/mode3_solvers.py --record 2
	$(PY) bench/mode3_solvers.py --breakdown
	$(PY) bench/min_violation_stop.py --record 2
	$(PY) bench/min_violation_stop.py
	$(PY) bench/campaign_throughput.py
	$(PY) bench/mode2_warm_start.py --record 6
	$(PY) bench/mode2_warm_start.py
	$(PY) bench/step_times.py

assets: $(VENV)/.installed
	$(PY) -m uvms_mj.export

clean:
	rm -rf out .pytest_cache
