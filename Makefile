# Two entry points on a fresh machine (see README):
#   make demo   - create .venv, install everything, run the main job (planners vs shipped agents)
#   make test   - create .venv, install everything, lint and run the test suite (examples/
#                 included, tests/examples), then `make test-oldest`
#   make test-oldest - the env and SB3 tests in .venv-oldest, on the oldest supported releases
PYTHON ?= python3.11
VENV ?= .venv
PY := $(VENV)/bin/python
# torch is pinned here (not in pyproject, which keeps torch>=2.3) so that pip takes the
# CPU build on this machine's local index instead of resolving a multi-GB CUDA build; the
# constraints file keeps it so while pip installs the extras (torchrl, tianshou, rl-zoo3).
TORCH_SPEC ?= torch==2.13.0
CONSTRAINTS ?= .ci/constraints.txt
# The oldest releases the env supports (pyproject's floors; SB3 2.3.2 is the last to accept
# Gymnasium 0.29, 2.3.0 being yanked), tested in a venv of their own.
OLDEST_VENV ?= .venv-oldest
OLDEST_PINS ?= numpy==1.24.4 gymnasium==0.29.1 stable-baselines3==2.3.2 pytest
OLDEST_TESTS ?= tests/envs/test_single.py tests/envs/test_registration.py tests/envs/test_random_env.py \
	tests/model/test_config.py tests/model/test_channel.py tests/envs/test_policies.py tests/model/test_trajectory.py \
	tests/model/test_peak.py tests/envs/test_rendering.py tests/test_optional.py \
	tests/examples/test_example_sb3.py tests/examples/test_example_cleanrl.py

.PHONY: demo test test-oldest docs lint format bench clean

$(VENV)/.installed: pyproject.toml Makefile $(CONSTRAINTS)
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "need $(PYTHON) (set PYTHON=...)"; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -c $(CONSTRAINTS) "$(TORCH_SPEC)"
	$(PY) -m pip install -q -c $(CONSTRAINTS) -e ".[all]"
	touch $@

$(OLDEST_VENV)/.installed: pyproject.toml Makefile $(CONSTRAINTS)
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "need $(PYTHON) (set PYTHON=...)"; exit 1; }
	test -x $(OLDEST_VENV)/bin/python || $(PYTHON) -m venv $(OLDEST_VENV)
	$(OLDEST_VENV)/bin/python -m pip install -q --upgrade pip
	$(OLDEST_VENV)/bin/python -m pip install -q -c $(CONSTRAINTS) "$(TORCH_SPEC)"
	$(OLDEST_VENV)/bin/python -m pip install -q -c $(CONSTRAINTS) -e . $(OLDEST_PINS)
	touch $@

demo: $(VENV)/.installed
	$(PY) -m ios_uav_env --out out/demo.png
	$(PY) -m agents.evaluate --shipped --out out/compare

test: $(VENV)/.installed docs
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(PY) -m pytest -q -n 2 --durations=15
	$(MAKE) test-oldest

# the oldest end of the supported range (the main venv is the newest)
test-oldest: $(OLDEST_VENV)/.installed
	$(OLDEST_VENV)/bin/python -c "import gymnasium, numpy, stable_baselines3 as sb3; \
		print('oldest: gymnasium', gymnasium.__version__, 'numpy', numpy.__version__, 'SB3', sb3.__version__)"
	$(OLDEST_VENV)/bin/python -m pytest -q -p no:cacheprovider $(OLDEST_TESTS)

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

format: $(VENV)/.installed
	$(VENV)/bin/ruff check --fix . && $(VENV)/bin/ruff format .

docs: $(VENV)/.installed
	$(VENV)/bin/mkdocs build --strict --site-dir site

bench: $(VENV)/.installed
	$(PY) benchmarks/step_speed.py

clean:
	rm -rf $(VENV) $(OLDEST_VENV) .pytest_cache .ruff_cache build *.egg-info
