# The two commands a user needs: `make demo` and `make test` (`make test-all` adds the tests
# marked slow, and Debian's chromium that one of them opens the report in; CI runs it). Each
# sets up whatever is missing first: Debian's ngspice, a virtual environment, the package.
VENV    ?= .venv
PY      := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
DEBS    := ngspice libngspice0 libngspice0-dev gcc
# The cross toolchains and simulators the corrector is verified on (firmware --target): avr-gcc
# and simavr for the ATmega328P, arm-none-eabi-gcc and QEMU for Cortex-M; all from Debian.
TOOLCHAIN_DEBS := gcc-avr avr-libc simavr libsimavr-dev gcc-arm-none-eabi libnewlib-arm-none-eabi \
                  qemu-system-arm
# (what only the whole suite needs: the HTML report opened in a real browser, the toolchains)
TEST_DEBS := chromium $(TOOLCHAIN_DEBS)
SUDO    := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
DEMO_OUT ?= demo-output

.PHONY: demo test test-all docs setup system-deps test-system-deps toolchains netlists bench clean

demo: setup
	$(VENV)/bin/creepcomp demo --out $(DEMO_OUT)

# Tests run on every core (pytest-xdist), a test file to a worker so that its module fixtures
# are made once; `slow` marks the tests over 4 s there (see pyproject.toml).
PYTEST  := $(PY) -m pytest -q -n auto --dist loadfile

test: setup
	$(PYTEST) -m "not slow"

test-all: setup test-system-deps
	$(PYTEST)

setup: system-deps $(STAMP)

system-deps:
	@dpkg -s $(DEBS) >/dev/null 2>&1 || { \
	  echo "installing $(DEBS) from Debian"; \
	  $(SUDO) apt-get update -q && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -q $(DEBS); }

test-system-deps:
	@dpkg -s $(TEST_DEBS) >/dev/null 2>&1 || { \
	  echo "installing $(TEST_DEBS) from Debian"; \
	  $(SUDO) apt-get update -q && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -q $(TEST_DEBS); }

# `make toolchains`: what `creepcomp firmware --verify RECORD --target avr|cortex-m0plus|cortex-m4f`
# needs, installed from Debian when missing (never a download).
toolchains:
	@dpkg -s $(TOOLCHAIN_DEBS) >/dev/null 2>&1 || { \
	  echo "installing $(TOOLCHAIN_DEBS) from Debian"; \
	  $(SUDO) apt-get update -q && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -q $(TOOLCHAIN_DEBS); }

$(STAMP): pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test,docs,bench]'
	touch $(STAMP)

# The documentation site (docs/, mkdocs.yml) into site/; warnings are errors.
docs: setup
	@$(PY) -c "import mkdocs, material, mkdocstrings_handlers.python, mkdocs_jupyter" 2>/dev/null || \
	  $(PY) -m pip install -q -e '.[docs]'
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict -d site

# Reference netlists of the bundled designs (a test fails when they are stale).
netlists: setup
	$(PY) -c "from creepcomp.verify.netlist import write_reference_netlists as w; w('netlists')"

clean:
	rm -rf $(VENV) $(DEMO_OUT) .pytest_cache .hypothesis

.PHONY: bench-digital
bench-digital: setup
	$(PY) benchmarks/digital_throughput.py

.PHONY: bench-diagnose
bench-diagnose: setup
	$(PY) benchmarks/diagnose_timing.py
	$(PY) benchmarks/diagnose_confusion.py --per-effect 20 --clean 40
	$(PY) benchmarks/diagnose_circuit_confusion.py --per-effect 20 --clean 40
