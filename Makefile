# Set-up and entry points. `make serve` and `make test` work on a fresh machine.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: install serve test bench lint clean fuzz stress

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test,view]'
	touch $(STAMP)

install: $(STAMP)

serve: $(STAMP)
	$(VENV)/bin/xarm-emu serve $(ARGS)

test: $(STAMP)
	$(PY) -m pytest $(PYTEST_ARGS)

bench: $(STAMP)
	$(PY) -m bench

# Random exploration beyond the deterministic examples of `make test` (FUZZ_SCALE times as many).
FUZZ_SCALE ?= 25
fuzz: $(STAMP)
	HYPOTHESIS_PROFILE=explore XARM_EMU_FUZZ_SCALE=$(FUZZ_SCALE) $(PY) -m pytest -q tests/test_controller_fuzz.py \
		tests/test_protocol_frame.py tests/test_model_rotations.py

# The reliability suite at full length: a one-minute pipelining flood, the ten-minute ten-reader
# develop soak, plus the bounded floods of `make test` (tests/test_robust_*.py).
stress: $(STAMP)
	XARM_EMU_STRESS=1 $(PY) -m pytest -q -p no:randomly tests/test_robust_*.py

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests bench
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

clean:
	rm -rf $(VENV) build *.egg-info src/*.egg-info
