# Gait Studio: two entry points for a fresh machine, `make demo` and `make test`.
# Each installs what it needs: a .venv from pyproject.toml and, when running as root on
# Debian without them, the system packages for headless OpenGL and Xvfb.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
BLENDER_VENV := .venv-blender
BLENDER_STAMP := $(BLENDER_VENV)/.installed
DEMO_DIR ?= build/demo

export PYQTGRAPH_QT_LIB := PySide6
export PYOPENGL_PLATFORM := egl

.PHONY: demo test benchmark system-deps clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --disable-pip-version-check -e '.[dev]'
	$(BIN)/python scripts/fetch_saliency_model.py resources/models/u2netp.onnx
	touch $@

# Blender 4.5 (bpy) pins NumPy < 2, which the project's venv cannot take: it gets its own,
# used only by tests/gaitcore/test_blender.py. bpy has wheels for Python 3.11 on Linux x86-64.
$(BLENDER_STAMP): pyproject.toml
	@if $(PYTHON) -c 'import platform, sys; sys.exit(not (sys.version_info[:2] == (3, 11) and platform.system() == "Linux" and platform.machine() == "x86_64"))'; then \
		$(PYTHON) -m venv $(BLENDER_VENV) && \
		$(BLENDER_VENV)/bin/pip install --quiet --disable-pip-version-check "$$($(PYTHON) -c 'import tomllib; print(tomllib.load(open("pyproject.toml", "rb"))["project"]["optional-dependencies"]["blender"][0])')"; \
	else \
		echo "bpy has no wheel for this Python or platform: the Blender test will be skipped"; \
		mkdir -p $(BLENDER_VENV); \
	fi
	touch $@

system-deps:
	@sh scripts/install-system-deps.sh

demo: $(STAMP) system-deps
	sh scripts/demo.sh $(BIN) $(DEMO_DIR)

test: $(STAMP) $(BLENDER_STAMP) system-deps
	$(BIN)/lint-imports
	$(BIN)/ruff check .
	$(BIN)/mypy
	sh scripts/run-tests.sh $(BIN)

benchmark: $(STAMP) system-deps
	$(BIN)/python -m benchmarks

clean:
	rm -rf $(VENV) $(BLENDER_VENV) build .pytest_cache .hypothesis
