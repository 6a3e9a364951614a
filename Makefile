# Two commands do everything on a fresh Linux machine (no GPU needed):
#   make demo   create .venv, install, run the end-to-end demo (collect -> train residual -> evaluate)
#   make test   create .venv, install, lint (ruff, and import-linter's layers contract) and run the test suite
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
export MUJOCO_GL ?= egl
export PYOPENGL_PLATFORM ?= egl
export HF_HUB_OFFLINE ?= 1

.PHONY: install demo test lint clean

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $@

install: $(BIN)/.installed

demo: install
	$(BIN)/bimanualshift demo

# Two pytest workers, one per core; a test file stays on one worker (its fixtures are built once there). The 15
# slowest tests are listed at the end, to keep the suite under its 8-minute budget (447 s of pytest at 40cf502 on 2 cores).
test: install lint
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --durations=15

lint: install
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/lint-imports --no-cache

clean:
	rm -rf $(VENV) runs
