# walker_gait: everything starts from `make demo` or `make test` on a fresh machine.
# Needs only Python >= 3.11, a C compiler and CMake; `make setup` builds .venv (idempotent).
SHELL := /bin/bash
VENV ?= .venv
PY := $(VENV)/bin/python
OUT ?= out
ARGS ?=

.PHONY: setup demo demo-live test test-fast bench sweep probes clean distclean help

help:
	@echo "make demo   - set up and run the offline pipeline on the bundled sample session"
	@echo "make test   - set up and run the test suite"
	@echo "make bench  - set up and run the benchmarks (writes BENCHMARKS.md)"
	@echo "make sweep  - accuracy over many sessions x tracker seeds (ARGS=\"--out DIR [--override JSON]\")"
	@echo "make probes - set up and run the probe battery: users, clothes, cameras, mounts unlike the bench's (writes PROBES.md)"
	@echo "make setup  - only build .venv (ROS 2 Jazzy wheels, walker_gait_msgs, walker_gait)"

setup:
	@bash tools/bootstrap.sh

demo: setup
	@$(PY) -m walker_gait.cli demo --out $(OUT)/demo $(ARGS)

demo-live: setup
	@$(PY) -m walker_gait.cli demo --live --out $(OUT)/demo-live $(ARGS)

test: setup
	@bash tools/run_tests.sh $(ARGS)

bench: setup
	@OMP_NUM_THREADS=$${OMP_NUM_THREADS:-1} $(PY) -m walker_gait.bench $(ARGS)

sweep: setup
	@OMP_NUM_THREADS=$${OMP_NUM_THREADS:-1} $(PY) -m walker_gait.bench.sweep $(ARGS)

probes: setup
	@OMP_NUM_THREADS=$${OMP_NUM_THREADS:-1} $(PY) -m walker_gait.bench.probes $(ARGS)

clean:
	rm -rf build $(OUT) .pytest_cache .hypothesis

distclean: clean
	rm -rf $(VENV)
