#!/usr/bin/env bash
# Install the package with its test dependencies, the headless Chromium the page
# tests drive (Debian's package; Playwright's own browser download is not used),
# and run the whole suite.
set -euo pipefail
cd "$(dirname "$0")/.."
python -m pip install -q -e ".[test]"
if [ ! -x /usr/bin/chromium ]; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  else
    sudo apt-get update -qq && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  fi
fi
if [ $# -gt 0 ] || [ "${PNEUCORE_TESTS_SERIAL:-0}" = 1 ]; then
  exec python -m pytest -q --durations=30 "$@"
fi
# The whole suite in two processes side by side: the page tests (mostly waiting on a browser
# and a server) and the API tests beside the rest (mostly computing), so that the suite's wall
# time stays well under CI's 20 minutes on 2 cores (one process after the other took 18
# minutes; with the page tests alone beside the rest, 16.6 minutes, the page group done after
# 5); each group runs as it would alone, and the page group's report is printed after the
# rest's. PNEUCORE_TESTS_SERIAL=1 runs them one after the other.
page_log=$(mktemp)
trap 'rm -f "$page_log"' EXIT
python -m pytest -q -p no:cacheprovider --durations=10 tests/page tests/api >"$page_log" 2>&1 &
page_pid=$!
rest=0
python -m pytest -q --durations=30 --ignore=tests/page --ignore=tests/api || rest=$?
page=0
wait "$page_pid" || page=$?
echo "========================== page and API tests =========================="
cat "$page_log"
[ "$rest" -eq 0 ] && [ "$page" -eq 0 ]
