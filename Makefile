# Gait Studio: two entry points for a fresh machine, `make demo` and `make test`.
# Each installs what it needs: a .venv from pyproject.toml and, when running as root on
# Debian without them, the system packages for headless OpenGL and Xvfb.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_DIR ?= build/demo

export PYQTGRAPH_QT_LIB := PySide6
export PYOPENGL_PLATFORM := egl

.PHONY: demo test benchmark system-deps clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --disable-pip-version-check -e '.[dev]'
	touch $@

system-deps:
	@sh scripts/install-system-deps.sh

demo: $(STAMP) system-deps
	sh scripts/demo.sh $(BIN) $(DEMO_DIR)

test: $(STAMP) system-deps
	$(BIN)/lint-imports
	$(BIN)/ruff check .
	$(BIN)/mypy
	sh scripts/run-tests.sh $(BIN)

benchmark: $(STAMP) system-deps
	$(BIN)/python -m benchmarks

clean:
	rm -rf $(VENV) build .pytest_cache .hypothesis
