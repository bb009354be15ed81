# Every target bootstraps the virtual environment first: nothing is installed by hand.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup lock notebook test test-fast test-random lint format fig4 sweeps sweep modes gtm-damage monitor monitor-oracle monitor-lateral references simultaneous manoeuvres excitations bench clean

setup: $(STAMP)

# Exactly the versions in requirements.lock (every runtime and test dependency, pip and the
# build tools included), then the project itself on top, without letting pip resolve anything.
$(STAMP): pyproject.toml requirements.lock
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.lock
	# setuptools warns that a folder named like the package in the working directory takes
	# precedence on imports: in this flat, editable layout that folder is the package itself.
	PYTHONWARNINGS="ignore:Editable installation:UserWarning" $(PY) -m pip install --quiet \
	  --disable-pip-version-check --no-deps --no-build-isolation -e .
	$(PY) -m pip check --disable-pip-version-check
	touch $(STAMP)

# Refresh requirements.lock: the newest releases that pyproject.toml admits, resolved in a
# throw-away environment.  Then run `make test` and commit the lock if it passes.
LOCK_VENV := .venv-lock
lock:
	rm -rf $(LOCK_VENV)
	$(PYTHON) -m venv $(LOCK_VENV)
	$(LOCK_VENV)/bin/python -m pip install --quiet --disable-pip-version-check --upgrade pip setuptools wheel
	$(LOCK_VENV)/bin/python -m pip install --quiet --disable-pip-version-check '.[dev]'
	{ echo "# Exact versions of every dependency (runtime, test, build), installed by make setup."; \
	  echo "# CPython $$($(LOCK_VENV)/bin/python -c 'import platform; print(platform.python_version())') on x86-64 Linux. Refresh: make lock, then make test."; \
	  $(LOCK_VENV)/bin/python -m pip freeze --all --disable-pip-version-check --exclude probing; } > requirements.lock
	$(LOCK_VENV)/bin/python -m pip install --quiet --disable-pip-version-check '.[notebook]' -c requirements.lock
	{ echo "# The JupyterLab front end of make notebook (and the notebook extra), exact versions, installed"; \
	  echo "# into .venv beside requirements.lock, which constrains it (nothing pinned there moves)."; \
	  echo "# CPython $$($(LOCK_VENV)/bin/python -c 'import platform; print(platform.python_version())') on x86-64 Linux. Refresh: make lock."; \
	  $(LOCK_VENV)/bin/python -m pip freeze --all --disable-pip-version-check --exclude probing \
	    | grep -v -x -F -f requirements.lock; } > requirements-notebook.lock
	rm -rf $(LOCK_VENV) build probing.egg-info

# The quickstart notebook (examples/notebooks, docs/api.md) in JupyterLab: the front end,
# pinned in requirements-notebook.lock, goes into .venv once, constrained by requirements.lock
# (nothing make setup installed moves, so make test runs as before); the kernel is .venv's.
# The notebook saves into a temporary folder: running it leaves the repository as it was.
NOTEBOOK_STAMP := $(VENV)/.notebook
# JupyterLab refuses to run as root unless told (a container's user often is).
notebook: $(NOTEBOOK_STAMP)
	$(VENV)/bin/jupyter lab examples/notebooks/quickstart.ipynb \
	  $(if $(filter 0,$(shell id -u)),--allow-root) $(NOTEBOOK_ARGS)

$(NOTEBOOK_STAMP): $(STAMP) requirements-notebook.lock
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements-notebook.lock \
	  -c requirements.lock
	$(PY) -m pip check --disable-pip-version-check
	touch $@

lint: setup
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .
	$(VENV)/bin/lint-imports --no-cache --no-logo

format: setup
	$(PY) -m ruff format .
	$(PY) -m ruff check --fix .

# The whole suite, on every core the machine has (pytest-xdist; TEST_WORKERS=1 runs it in
# this process, TEST_WORKERS=4 on four), each worker taking the next test as it is free;
# the 25 slowest tests are listed at the end, so CI shows the next slow test as it lands.
TEST_WORKERS ?= logical
TEST_ARGS = -n $(TEST_WORKERS) --dist worksteal --durations=25
test: setup lint
	$(PY) -m pytest $(TEST_ARGS)

# The inner loop while developing (under a minute): the numerical core, the scenario rules
# and the command line's refusals, without the tests that fly JSBSim.  make test before a
# commit: it is the whole suite.
FAST_TESTS := probing/core tests/core tests/experiment/test_scenario.py \
  tests/experiment/test_scenario_sections.py tests/experiment/test_scenario_sensors.py \
  tests/test_scenarios.py tests/cli
test-fast: setup
	$(PY) -m pytest $(FAST_TESTS) -m "not jsbsim and not slow" -n $(TEST_WORKERS) -q

# The whole suite in a random order across files (pytest-random-order), to show that no test
# depends on another's leftovers; the header prints the seed, SEED=<it> repeats that order.
test-random: setup
	$(PY) -m pytest $(TEST_ARGS) --random-order-bucket=global \
	  $(if $(SEED),--random-order-seed=$(SEED))

fig4: setup
	$(PY) -m probing fig4

# Batch sweeps (docs/sweeps.md): every file in scenarios/sweeps, or one with SWEEP=<file>.
# Resumable: rerun after an interruption and only the missing points are computed.
SWEEPS   := $(sort $(wildcard scenarios/sweeps/*.toml))
SWEEP_OUT ?= results/sweeps
JOBS     ?=
SWEEP_ARGS = --out $(SWEEP_OUT) $(if $(JOBS),-j $(JOBS))

# The provided sweeps draw their figures into the committed figures/ (docs/sweeps.md).
sweeps: setup
	@for f in $(SWEEPS); do $(PY) -m probing sweep $$f $(SWEEP_ARGS) --plot --figures figures || exit $$?; done

sweep: setup
	@test -n "$(SWEEP)" || { echo "usage: make sweep SWEEP=scenarios/sweeps/<file>.toml [JOBS=n]" >&2; exit 2; }
	$(PY) -m probing sweep $(SWEEP) $(SWEEP_ARGS) --plot --figures figures

# The GTM's mode table (docs/gtm.md) and figure (figures/gtm_modes.png), named here: the
# bare command writes into results/modes (committed files change only when asked).
modes: setup
	$(PY) -m probing modes --docs docs/gtm.md --figure figures/gtm_modes

# NASA's Example 6: the six GTM damage cases in a climbing turn (docs/gtm.md); its figures
# into the committed figures/ (the bare command: results/gtm_damage/figures).
gtm-damage: setup
	$(PY) -m probing gtm-damage --figures figures

# The health-monitoring study on what the aircraft measures (docs/monitoring.md): every sweep
# in scenarios/monitor-realisable (written by its generate.py; GTM, NASA's T2 sensors, the
# realisable references gust and detrend and the oracle as the bound; faults at 0.2 and
# 0.02 deg, the dead band over the probe's amplitude in calm air, light and moderate
# turbulence; 40 one-hour flights without a fault), resumable, JOBS=n workers,
# EXECUTOR=dask for a Dask LocalCluster of JOBS workers, or EXECUTOR=dask
# SCHEDULER=tcp://host:8786 on a running Dask cluster (docs/sweeps.md, "On a cluster": its
# workers run this checkout's venv at the same path and share MONITOR_OUT); then its table
# (docs/monitoring_summary.md) and figures (figures/monitor_*.png).
MONITOR_SWEEPS := $(sort $(wildcard scenarios/monitor-realisable/*.toml))
MONITOR_OUT ?= results/monitor
EXECUTOR ?=
SCHEDULER ?=
monitor: setup
	@for f in $(MONITOR_SWEEPS); do \
	  $(PY) -m probing sweep $$f --out $(MONITOR_OUT) $(if $(JOBS),-j $(JOBS)) \
	    $(if $(EXECUTOR),--executor $(EXECUTOR)) $(if $(SCHEDULER),--scheduler $(SCHEDULER)) \
	    > /dev/null || exit $$?; done
	$(PY) -m probing plot monitor $(MONITOR_OUT) --figures figures --summary docs/monitoring_summary.md

# The first monitor study, with the oracle reference only (the twin that knows the gusts;
# docs/monitoring.md, "The oracle study"): every sweep in scenarios/monitor (written by
# scenarios/monitor/generate.py), then its table (docs/monitoring_oracle_summary.md) and
# figures (figures/oracle/monitor_*.png).
ORACLE_SWEEPS := $(sort $(wildcard scenarios/monitor/*.toml))
ORACLE_OUT ?= results/monitor-oracle
monitor-oracle: setup
	@for f in $(filter-out scenarios/monitor/base.toml,$(ORACLE_SWEEPS)); do \
	  $(PY) -m probing sweep $$f --out $(ORACLE_OUT) $(if $(JOBS),-j $(JOBS)) \
	    $(if $(EXECUTOR),--executor $(EXECUTOR)) $(if $(SCHEDULER),--scheduler $(SCHEDULER)) \
	    > /dev/null || exit $$?; done
	$(PY) -m probing plot monitor $(ORACLE_OUT) --figures figures/oracle \
	  --summary docs/monitoring_oracle_summary.md

# What each reference leaves of the gusts (docs/monitoring.md, "References a real aircraft
# could run"): 60 monitored flights without a fault, four references x calm, light and
# moderate turbulence x five seeds, NASA's T2 sensors (about a minute on two cores); then its
# table (docs/references_summary.md) and figure (figures/references_scatter.png).
REFERENCES_OUT ?= results/references
references: setup
	$(PY) -m probing sweep scenarios/references/references.toml --out $(REFERENCES_OUT) \
	  $(if $(JOBS),-j $(JOBS)) $(if $(EXECUTOR),--executor $(EXECUTOR)) \
	  $(if $(SCHEDULER),--scheduler $(SCHEDULER)) > /dev/null
	$(PY) -m probing plot references $(REFERENCES_OUT) --figures figures \
	  --summary docs/references_summary.md

# NASA's lateral damage cases 1-4 with an aileron or a rudder probe (docs/monitoring.md,
# "Lateral damage"): every sweep in scenarios/monitor-lateral, then its table
# (docs/monitoring_lateral_summary.md); its figures stay in the results folder.
LATERAL_SWEEPS := $(sort $(wildcard scenarios/monitor-lateral/*-*.toml))
LATERAL_OUT ?= results/monitor-lateral
monitor-lateral: setup
	@for f in $(filter-out scenarios/monitor-lateral/base-%,$(LATERAL_SWEEPS)); do \
	  $(PY) -m probing sweep $$f --out $(LATERAL_OUT) $(if $(JOBS),-j $(JOBS)) \
	    $(if $(EXECUTOR),--executor $(EXECUTOR)) $(if $(SCHEDULER),--scheduler $(SCHEDULER)) \
	    > /dev/null || exit $$?; done
	$(PY) -m probing plot monitor $(LATERAL_OUT) --summary docs/monitoring_lateral_summary.md

# Several surfaces probed at once (docs/simultaneous.md): every scenario in
# scenarios/simultaneous flown together and each surface alone, then the cross-talk tables
# (docs/simultaneous_summary.md) and figures (figures/simultaneous_*.png).  About a minute.
SIMULTANEOUS_OUT ?= results/simultaneous
simultaneous: setup
	@for f in $(sort $(wildcard scenarios/simultaneous/*.toml)); do \
	  $(PY) -m probing run $$f --truth --out $(SIMULTANEOUS_OUT) > /dev/null || exit $$?; done
	$(PY) -m probing plot simultaneous $(SIMULTANEOUS_OUT) --figures figures \
	  --summary docs/simultaneous_summary.md

# Incremental probing through manoeuvres (docs/manoeuvres.md): every scenario in
# scenarios/manoeuvres (the GTM speeding up by 20 kt at 0.5 to 4 kt/s), then the table
# (docs/manoeuvres_summary.md) and figures (figures/manoeuvres_*.png).  About a minute.
MANOEUVRES_OUT ?= results/manoeuvres
manoeuvres: setup
	@for f in $(sort $(wildcard scenarios/manoeuvres/*.toml)); do \
	  $(PY) -m probing run $$f --out $(MANOEUVRES_OUT) > /dev/null || exit $$?; done
	$(PY) -m probing plot manoeuvres $(MANOEUVRES_OUT) --figures figures \
	  --summary docs/manoeuvres_summary.md

bench: setup
	$(PY) -m bench

# Generated outputs that are not committed; the committed figures and tables stay.
clean:
	rm -rf results .pytest_cache .hypothesis figures/sweep_*.pdf

# The PRBS against a multisine and a chirp on one budget (docs/excitations.md): the monitor
# sweeps in scenarios/excitations (written by its generate.py; GTM, light turbulence, NASA's
# T2 sensors, the gust reference), then the Fig. 4 sets of the GTM and the 737 flown with
# each signal, the tables (docs/excitations_summary.md) and figures (figures/excitations_*.png),
# named here (the bare command writes them into its --out).
EXCITATIONS_OUT ?= results/excitations
excitations: setup
	@for f in $(sort $(wildcard scenarios/excitations/*.toml)); do \
	  $(PY) -m probing sweep $$f --out $(EXCITATIONS_OUT)/monitor $(if $(JOBS),-j $(JOBS)) \
	    > /dev/null || exit $$?; done
	$(PY) -m probing excitations --out $(EXCITATIONS_OUT) --monitor $(EXCITATIONS_OUT)/monitor \
	  --figures figures --summary docs/excitations_summary.md $(if $(JOBS),-j $(JOBS))
