# `make run` and `make test` work on a fresh clone where only python3 exists.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
PREBUILT := pipeline/model/ik/_prebuilt_ik.json
OUT ?= out

.PHONY: run test test-slow test-kernels bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

# The IK kernels built at install (pipeline/model/ik/prebuilt.py): the first IK call then compiles nothing.
# Rebuilt when the sources they are compiled from change; without a C compiler IK compiles just in time.
# The same step compiles the planner's broad phase (pipeline/cell/broad_phase.py) and the kinematics and timing
# kernels a planned move uses (pipeline/cell/clear_motion.py: compile_motion_kernels) into Numba's cache.
$(PREBUILT): $(STAMP) $(wildcard pipeline/model/chain/*.py pipeline/model/ik/*.py pipeline/files/*.py) pipeline/cell/broad_phase.py \
		pipeline/timing/reachability.py pipeline/timing/hermite.py pipeline/timing/compiled_spline.py
	$(PY) -m pipeline build-kernels || true

# Demo: check every preset robot (Drake vs NumPy vs finite differences), print every demo cell
# (check-cell: its collision model and clearance at q = 0), then run every demo job in
# trajectories/jobs/ into $(OUT)/<job name>/ (profile CSV/NPZ, JSON report, PNG plot).
run: $(STAMP) $(PREBUILT)
	$(PY) -m pipeline check all --samples 200 --out $(OUT)/check
	@set -e; for robot in gp7 lrmate200id irb1600 ur5e arm5 arm6; do $(PY) -m pipeline export $$robot --urdf $(OUT)/urdf/$$robot.urdf; done
	@set -e; for cell in models/cells/*.yaml; do echo "== $$cell"; $(PY) -m pipeline check-cell $$cell; done
	@set -e; for job in trajectories/jobs/*.yaml; do \
		name=$$(basename $$job .yaml); \
		echo "== $$job"; \
		$(PY) -m pipeline run $$job --out $(OUT)/$$name; \
	done
	@echo "Jacobian check reports in $(OUT)/check/, the presets as URDF in $(OUT)/urdf/; the plots and 3-D views (open view.html in a browser):"
	@for job in trajectories/jobs/*.yaml; do n=$$(basename $$job .yaml); echo "  $(OUT)/$$n/profile.png  $(OUT)/$$n/arm.png  $(OUT)/$$n/view.html"; done

test: $(STAMP) $(PREBUILT)
	$(PY) -m pytest -m "not slow"

# The long runs (e.g. thousands of random paths through toppra, topp3 and Ruckig): CI runs them after `make test`.
test-slow: $(STAMP) $(PREBUILT)
	$(PY) -m pytest -m slow

# The golden profiles and the timing tests again under another OpenBLAS kernel (Prescott: no AVX, no FMA;
# NumPy's OpenBLAS names it Katmai): a tolerance that holds only for one kernel's round-off fails here.
# CI runs it after `make test-slow`.
test-kernels: $(STAMP) $(PREBUILT)
	OPENBLAS_CORETYPE=Prescott $(PY) -m pytest tests/test_runner.py -k golden
	OPENBLAS_CORETYPE=Prescott $(PY) -m pytest -m "not slow" tests/timing/test_timing.py tests/timing/test_topp3.py \
		tests/timing/test_ruckig.py tests/timing/test_profile.py

# Benchmarks beside the peers (installs the optional `bench` extra: Robotics Toolbox, Pinocchio).
bench: $(STAMP) $(PREBUILT)
	$(PY) -m pip install --quiet -e ".[test,bench]"
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench kinematics
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench ik
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench timing
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench cartesian
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench plan
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench broad-phase
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench cycle
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench scale
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench job
	OMP_NUM_THREADS=1 $(PY) -m pipeline bench ui

clean:
	rm -rf $(VENV) $(OUT) pipeline/model/ik/_prebuilt_ik*
