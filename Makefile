# phyplan: one-command set-up. `make bench` and `make test` create .venv, install the package and run.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.phyplan-installed
# Headless rendering: EGL unless the user chose another backend. Must be set before mujoco is imported.
MUJOCO_GL ?= egl
export MUJOCO_GL
# One thread per process: faster on the 2-core machines and deterministic.
export OMP_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1

BENCH_OUT ?= results/bench
BENCH_ARGS ?=

.PHONY: all venv bench test test-fast skills skills-conditioned skills-general-bounce skills-paddles skills-bouncing-paddles baselines speed solvable clean

all: test

$(STAMP): setup.cfg pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e ".[dev]"
	touch $(STAMP)

venv: $(STAMP)

bench: $(STAMP)
	$(PY) -m benchmarks.run --out $(BENCH_OUT) --workers 2 --seeds 1 $(BENCH_ARGS)

test: $(STAMP)
	$(PY) -m pytest -q

# Everything but the tests marked slow (CI and `make test` run them all).
test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow"

skills: $(STAMP)
	$(PY) -m phyplan_agents.skills.train --all

# The parameter-conditioned skills of the hidden-physics track (training space only).
skills-conditioned: $(STAMP)
	$(PY) -m phyplan_agents.skills.train --conditioned

# The general-incidence bounce skills and the wall bounces (PINN and NN; the Bounce-v0 wedge contact and the varied
# track's impact pair).
skills-general-bounce: $(STAMP)
	$(PY) -m phyplan_agents.skills.train --general-bounce

# The Paddles task's skills (swing_wide, hit_wide, throw_wide, glide, bounce_general_low(_cond); PINN and NN).
skills-paddles: $(STAMP)
	$(PY) -m phyplan_agents.skills.train --paddles

# The skills of balls falling through bouncing paddles (bounce_general_fast, throw_fast; PINN and NN).
skills-bouncing-paddles: $(STAMP)
	$(PY) -m phyplan_agents.skills.train --bouncing-paddles

# The bounce off PaddlesVaried-v3's exact impacts (bounce_general_exact_cond; PINN and NN).
skills-exact-impacts: $(STAMP)
	$(PY) -m phyplan_agents.skills.train --exact-impacts

baselines: $(STAMP)
	$(PY) -m phyplan_agents.dqn.train --all
	$(PY) -m phyplan_agents.dqn.train --task paddles --paddles 1 2 3 4

speed: $(STAMP)
	$(PY) -m benchmarks.env_speed

solvable: $(STAMP)
	$(PY) -m benchmarks.solvability

clean:
	rm -rf $(VENV) results *.egg-info
