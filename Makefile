# tethernet_ros — common entry points. `make setup` builds .venv (see scripts/setup.sh).
SHELL := /bin/bash
VENV  := .venv
PY    := $(VENV)/bin/python
# keep DDS discovery on this host (Jazzy's default SUBNET multicasts on the LAN)
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

.PHONY: setup demo lint test test-fast bench clean

setup:
	bash scripts/setup.sh

demo: setup
	$(VENV)/bin/tethernet capture --design mass-min --via ros

lint: setup
	$(VENV)/bin/ruff check .

# two workers (pytest-xdist): the ROS tests on one of them, in order (tests/conftest.py)
test: lint
	$(PY) -m pytest -q -n 2 --dist loadgroup tests

test-fast: setup
	$(PY) -m pytest -q -n 2 --dist loadgroup -m "not slow" tests

bench: setup
	$(PY) benchmarks/bench_batch.py

clean:
	rm -rf $(VENV) build install log
