# Two entry points on a fresh machine (see README):
#   make demo   - create .venv, install everything, run the main job (planners vs shipped agents)
#   make test   - create .venv, install everything, lint and run the test suite
PYTHON ?= python3.11
VENV ?= .venv
PY := $(VENV)/bin/python
# torch is pinned here (not in pyproject, which keeps torch>=2.3) so that pip takes the
# CPU build on this machine's local index instead of resolving a multi-GB CUDA build.
TORCH_SPEC ?= torch==2.13.0

.PHONY: demo test docs lint format bench clean

$(VENV)/.installed: pyproject.toml Makefile
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "need $(PYTHON) (set PYTHON=...)"; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "$(TORCH_SPEC)"
	$(PY) -m pip install -q -e ".[all]"
	touch $@

demo: $(VENV)/.installed
	$(PY) -m ios_uav_env --out out/demo.png
	$(PY) -m agents.evaluate --shipped --out out/compare

test: $(VENV)/.installed docs
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(PY) -m pytest -q

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

format: $(VENV)/.installed
	$(VENV)/bin/ruff check --fix . && $(VENV)/bin/ruff format .

docs: $(VENV)/.installed
	$(VENV)/bin/mkdocs build --strict --site-dir site

bench: $(VENV)/.installed
	$(PY) benchmarks/step_speed.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache build *.egg-info
