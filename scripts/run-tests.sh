#!/usr/bin/env bash
# Runs the whole suite: everything but the browser tests, then the browser tests in a process of
# their own (Playwright's sync API keeps an event loop running in its thread, which the asyncio
# tests must not share). pytest's exit 5 (no tests collected) is a failure, never hidden.
set -uo pipefail
cd "$(dirname "$0")/.."
status=0
run() {
  .venv/bin/python -m pytest -q -p no:cacheprovider "$@"
  local rc=$?
  if [ "$rc" = 5 ]; then
    echo "pytest collected no tests in: $*" >&2
    rc=1
  fi
  [ "$rc" = 0 ] || status=1
}
run --ignore=tests/e2e "$@"
run tests/e2e "$@"
exit "$status"
