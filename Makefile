# tethernet_ros — common entry points. `make setup` builds .venv (see scripts/setup.sh).
SHELL := /bin/bash
VENV  := .venv
PY    := $(VENV)/bin/python
# keep DDS discovery on this host (Jazzy's default SUBNET multicasts on the LAN)
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

.PHONY: setup demo lint test test-all bench clean

setup:
	bash scripts/setup.sh

demo: setup
	$(VENV)/bin/tethernet capture --design mass-min --via ros

lint: setup
	$(VENV)/bin/ruff check .

# the fast tier (CI): two pytest processes side by side (scripts/test.sh), the ROS tests in
# order with the longest core modules, the rest; the slow tier is left out (tests/conftest.py)
test: lint
	TEST_MARK="not slow" bash scripts/test.sh

# both tiers: the fast one and the slow studies and costlier repeats (about 45 CPU-min)
test-all: lint
	bash scripts/test.sh

bench: setup
	$(PY) benchmarks/bench_batch.py

clean:
	rm -rf $(VENV) build install log
