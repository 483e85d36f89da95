#!/usr/bin/env bash
# Runs the whole suite in three pytest processes, each with its own exit status:
# - everything but the browser tests and the REST fuzzer, on pytest-xdist workers, a test file
#   per worker at a time (a file's module fixtures are set up once; every test starts its own
#   brokers and processes on free ports, so files do not share state);
# - beside it, one after the other: the REST fuzzer
#   (tests/integration/ground/test_ground_openapi_fuzz.py; schemathesis gives all its cases one
#   node id, which xdist cannot spread) and the browser tests (Playwright's sync API keeps an
#   event loop running in its thread, which the asyncio tests must not share).
# Measured on 2 cores: alone, the fuzzer takes 2 min, the browser tests 6, the rest 13. All three
# at once took 34 min (the fuzzer alone 25 of them: each of its ~13,000 calls waited behind the
# other two suites' processes); two at a time, the fuzzer and browser tests in turn beside the
# rest, stays under 20.
# pytest's exit 5 (no tests collected) is a failure, never hidden. Each part prints its 25
# slowest tests, so a CI log says where the time went.
set -uo pipefail
cd "$(dirname "$0")/.."
FUZZ=tests/integration/ground/test_ground_openapi_fuzz.py
# Two workers beside the fuzzer and browser tests: with three, on a machine half as fast as the
# one measured above, the suite took 28 min and timing tests starved (load 10 on 2 cores).
WORKERS="${DRONEFLEET_TEST_WORKERS:-2}"
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
e2e_log="$(mktemp)"
rcs="$(mktemp -d)"
(
  pytest "$FUZZ" --durations=10 "$@" >"$fuzz_log" 2>&1
  echo $? >"$rcs/fuzz"
  pytest tests/e2e --durations=25 "$@" >"$e2e_log" 2>&1
  echo $? >"$rcs/e2e"
) &
beside=$!
pytest -n "$WORKERS" --dist loadfile --durations=25 --ignore=tests/e2e --ignore="$FUZZ" "$@"
check $? "the suite but the browser tests and the fuzzer"
wait "$beside"
echo "--- $FUZZ"
cat "$fuzz_log"
check "$(cat "$rcs/fuzz")" "$FUZZ"
echo "--- tests/e2e"
cat "$e2e_log"
check "$(cat "$rcs/e2e")" tests/e2e
rm -rf "$fuzz_log" "$e2e_log" "$rcs"
exit "$status"
