#!/usr/bin/env bash
# Runs the whole suite in three pytest processes, each with its own exit status:
# - everything but the browser tests and the REST fuzzer, on pytest-xdist workers, a test file
#   per worker at a time (a file's module fixtures are set up once; every test starts its own
#   brokers and processes on free ports, so files do not share state);
# - the REST fuzzer (tests/integration/ground/test_ground_openapi_fuzz.py) alongside, in a
#   process of its own: schemathesis gives all its cases one node id, which xdist cannot spread
#   (under xdist one case of 59 ran);
# - then the browser tests, in a process of their own (Playwright's sync API keeps an event loop
#   running in its thread, which the asyncio tests must not share).
# pytest's exit 5 (no tests collected) is a failure, never hidden.
set -uo pipefail
cd "$(dirname "$0")/.."
FUZZ=tests/integration/ground/test_ground_openapi_fuzz.py
WORKERS="${DRONEFLEET_TEST_WORKERS:-3}"
status=0
check() {  # check RC WHAT: fold one pytest exit status into the suite's
  local rc=$1
  if [ "$rc" = 5 ]; then
    echo "pytest collected no tests in: $2" >&2
    rc=1
  fi
  [ "$rc" = 0 ] || status=1
}
pytest() {
  .venv/bin/python -m pytest -q -p no:cacheprovider "$@"
}
fuzz_log="$(mktemp)"
pytest "$FUZZ" "$@" >"$fuzz_log" 2>&1 &
fuzz_pid=$!
pytest -n "$WORKERS" --dist loadfile --ignore=tests/e2e --ignore="$FUZZ" "$@"
check $? "the suite but the browser tests and the fuzzer"
wait "$fuzz_pid"
fuzz_rc=$?
echo "--- $FUZZ"
cat "$fuzz_log"
rm -f "$fuzz_log"
check "$fuzz_rc" "$FUZZ"
pytest tests/e2e "$@"
check $? tests/e2e
exit "$status"
