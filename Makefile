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

# two pytest processes side by side (scripts/test.sh): the ROS tests in order with the longest core modules, the rest
test: lint
	bash scripts/test.sh

test-fast: setup
	TEST_MARK="not slow" bash scripts/test.sh

bench: setup
	$(PY) benchmarks/bench_batch.py

clean:
	rm -rf $(VENV) build install log
