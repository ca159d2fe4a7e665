#!/usr/bin/env bash
# unilod test command (README Quick start; .ci/run calls exactly this).
# Installs missing Debian packages, then builds and runs every test twice: an optimised build and
# an AddressSanitizer + UndefinedBehaviorSanitizer build with asserts on.
#   tools/test.sh            both builds
#   tools/test.sh --fast     optimised build only
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
source tools/deps.sh
unilod_ensure_packages
unilod_ensure_test_client

jobs=$(nproc)
run_suite() { # preset
    echo "== unilod: configure + build ($1) =="
    cmake --preset "$1" >/dev/null
    cmake --build --preset "$1" -j "$jobs"
    echo "== unilod: tests ($1) =="
    ctest --preset "$1" -j "$jobs"
}
run_suite default
if [ "${1:-}" != "--fast" ]; then
    run_suite asan
fi
