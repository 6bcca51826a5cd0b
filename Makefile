# Two entry points on a fresh machine (see README):
#   make demo   - create .venv, install everything, run the main job (planners vs shipped agents)
#   make test   - create .venv, install everything, lint and run the test suite (examples/ and
#                 the docs' strict build included: tests/examples, tests/test_docs.py); beside it
#                 the side venvs install, then `make test-oldest` and `make test-versions` run
#   make test-oldest - the env and SB3 tests in .venv-oldest, on the oldest supported releases
#   make test-versions - the wheel's own tests on the oldest and the newest supported Python
PYTHON ?= python3.11
VENV ?= .venv
PY := $(VENV)/bin/python
# Python caches the bytecode of what it imports, whatever the shell says: with PYTHONDONTWRITEBYTECODE
# exported, each of the hundred or so interpreters the tests start would compile torch,
# Stable-Baselines3, Ray and this package from source again, seconds each (the caches go to
# __pycache__ folders, which git ignores, in the venvs and the checkout).
unexport PYTHONDONTWRITEBYTECODE
# torch is pinned here (not in pyproject, which keeps torch>=2.3) so that pip takes the
# CPU build on this machine's local index instead of resolving a multi-GB CUDA build; the
# constraints file keeps it so while pip installs the extras (torchrl, tianshou, rl-zoo3).
# The venvs install with --no-compile: pip would byte-compile all of torch and the RL libraries
# (about half a CPU minute in the main venv, on the path to the main suite: pip installs on one
# core); Python compiles what the tests import, when they first do. Ray alone is compiled in the main
# venv after the install (a few CPU seconds on both cores): its node starts its processes within a
# timeout, and on a loaded machine compiling Ray's modules at that first start went past it.
TORCH_SPEC ?= torch==2.13.0
CONSTRAINTS ?= .ci/constraints.txt
# The oldest releases the env supports (pyproject's floors; SB3 2.3.2 is the last to accept
# Gymnasium 0.29, 2.3.0 being yanked), tested in a venv of their own.
OLDEST_VENV ?= .venv-oldest
OLDEST_PINS ?= numpy==1.24.4 gymnasium==0.29.1 stable-baselines3==2.3.2 pytest
OLDEST_TESTS ?= tests/envs/test_single.py tests/envs/test_registration.py tests/envs/test_random_env.py tests/envs/test_checkers.py \
	tests/model/test_config.py tests/model/test_channel.py tests/envs/test_policies.py tests/model/test_trajectory.py \
	tests/model/test_peak.py tests/envs/test_rendering.py tests/test_optional.py \
	tests/examples/test_example_sb3.py tests/examples/test_example_cleanrl.py
# The wheel's own tests (model, envs, benchmark: numpy, Gymnasium and scipy's LP) on the oldest
# Python minor of pyproject's requires-python and the newest one tested, each in .venv-py<minor>
# (.venv-py310 ...) with the newest releases that minor gets. No torch, no numba, no matplotlib:
# Gymnasium's checker, which renders a frame, and the compiled peak search are left out (-k), and so
# are the tests marked slow_without_numba (optimisers run many times: minutes in plain Python; the
# main suite runs them, and their code's plain-Python path is tested there too).
# A minor's interpreter is pyenv's build of it, else python<minor> on the PATH if it runs; with
# neither, the minor is skipped with a note (under CI, CI set, that is an error). pip compiles no
# bytecode there (--no-compile): the tests import a small part of what it installs.
TEST_PYTHONS ?= 3.10 3.13
PYENV_ROOT ?= $(HOME)/.pyenv
VERSION_PINS ?= pytest scipy
VERSION_TESTS ?= tests/model tests/envs/test_single.py tests/envs/test_registration.py \
	tests/envs/test_policies.py tests/envs/test_rollout.py tests/envs/test_multi.py \
	tests/benchmark/test_results.py -k "not check_env and not checker and not compiled_search" \
	-m "not slow_without_numba"
# the interpreter of Python $(1) (e.g. 3.10), empty if this machine has none that runs
python_of = $(firstword $(foreach c,$(wildcard $(PYENV_ROOT)/versions/$(1).*/bin/python$(1)) \
	$(shell command -v python$(1) 2>/dev/null),$(if $(shell $(c) -c 'print(1)' 2>/dev/null),$(c))))
# the minor of a venv's or a target's stem (310 -> 3.10)
minor_of = 3.$(patsubst 3%,%,$(1))

.PHONY: demo test test-main side side-venvs test-oldest test-versions docs lint format bench clean

$(VENV)/.installed: pyproject.toml Makefile $(CONSTRAINTS)
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "need $(PYTHON) (set PYTHON=...)"; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q --no-compile -c $(CONSTRAINTS) "$(TORCH_SPEC)"
	$(PY) -m pip install -q --no-compile -c $(CONSTRAINTS) -e ".[all]"
	$(PY) -m compileall -q -j 0 "$$($(PY) -c 'import os, ray; print(os.path.dirname(ray.__file__))')"
	touch $@

$(OLDEST_VENV)/.installed: pyproject.toml Makefile $(CONSTRAINTS)
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "need $(PYTHON) (set PYTHON=...)"; exit 1; }
	test -x $(OLDEST_VENV)/bin/python || $(PYTHON) -m venv $(OLDEST_VENV)
	$(OLDEST_VENV)/bin/python -m pip install -q --upgrade pip
	$(OLDEST_VENV)/bin/python -m pip install -q --no-compile -c $(CONSTRAINTS) "$(TORCH_SPEC)"
	$(OLDEST_VENV)/bin/python -m pip install -q --no-compile -c $(CONSTRAINTS) -e . $(OLDEST_PINS)
	touch $@

.PRECIOUS: .venv-py%/.installed
.venv-py%/.installed: pyproject.toml Makefile $(CONSTRAINTS)
	@test -n "$(call python_of,$(call minor_of,$*))" || { echo "no Python $(call minor_of,$*) here"; exit 1; }
	test -x .venv-py$*/bin/python || $(call python_of,$(call minor_of,$*)) -m venv .venv-py$*
	.venv-py$*/bin/python -m pip install -q --no-compile -c $(CONSTRAINTS) -e . $(VERSION_PINS)
	touch $@

demo: $(VENV)/.installed
	$(PY) -m ios_uav_env --out out/demo.png
	$(PY) -m agents.evaluate --shipped --out out/compare --overwrite

# Two chains side by side from the start: the main one (install .venv, lint, the suite on two
# workers) and the side one (install the side venvs, oldest releases and other Pythons, then run
# their tests). The side installs run at the lowest CPU priority while the main venv installs
# (pip mostly waits on the disk there: a core is free), their tests at a low one while the main
# suite runs, in the time its workers wait on processes, Ray and signals; nice 10, not 19, so
# that their subprocesses still get a share of a busy core within their timeouts. The docs'
# strict build is a test of the suite (tests/test_docs.py), not a step of its own.
test:
	$(MAKE) -j2 --output-sync=target test-main side

test-main: $(VENV)/.installed
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(PY) -m pytest -q -n 2 --dist worksteal --durations=15

side: side-venvs
	nice -n 10 $(MAKE) -j3 --output-sync=target test-oldest test-versions

side-venvs:
	nice -n 19 $(MAKE) -j3 $(OLDEST_VENV)/.installed \
		$(foreach v,$(TEST_PYTHONS),$(if $(call python_of,$(v)),.venv-py$(subst .,,$(v))/.installed))

# the oldest end of the supported range (the main venv is the newest)
test-oldest: $(OLDEST_VENV)/.installed
	$(OLDEST_VENV)/bin/python -c "import gymnasium, numpy, stable_baselines3 as sb3; \
		print('oldest: gymnasium', gymnasium.__version__, 'numpy', numpy.__version__, 'SB3', sb3.__version__)"
	$(OLDEST_VENV)/bin/python -m pytest -q -p no:cacheprovider $(OLDEST_TESTS)

# every minor of TEST_PYTHONS (test-py310 ...); a minor's venv is a prerequisite only where its
# Python is found
test-versions: $(foreach v,$(TEST_PYTHONS),test-py$(subst .,,$(v)))

.SECONDEXPANSION:
test-py%: $$(if $$(call python_of,$$(call minor_of,$$*)),.venv-py$$*/.installed)
	@if [ -z "$(call python_of,$(call minor_of,$*))" ]; then \
		where="no $(PYENV_ROOT)/versions/$(call minor_of,$*).*/bin/python$(call minor_of,$*), no python$(call minor_of,$*) that runs on the PATH"; \
		if [ -n "$$CI" ]; then echo "Python $(call minor_of,$*): not found ($$where); CI tests every minor of TEST_PYTHONS" >&2; exit 1; fi; \
		echo "Python $(call minor_of,$*): not found ($$where): skipped"; exit 0; \
	fi; \
	.venv-py$*/bin/python -c "import sys, gymnasium, numpy, scipy; print('Python', sys.version.split()[0], \
		'gymnasium', gymnasium.__version__, 'numpy', numpy.__version__, 'scipy', scipy.__version__)" && \
	.venv-py$*/bin/python -m pytest -q -p no:cacheprovider $(VERSION_TESTS)

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

format: $(VENV)/.installed
	$(VENV)/bin/ruff check --fix . && $(VENV)/bin/ruff format .

docs: $(VENV)/.installed
	$(VENV)/bin/mkdocs build --strict --site-dir site

bench: $(VENV)/.installed
	$(PY) benchmarks/step_speed.py

clean:
	rm -rf $(VENV) $(OLDEST_VENV) .venv-py3* .pytest_cache .ruff_cache build *.egg-info
