#!/usr/bin/env bash
# One command on a fresh Debian 12: install dependencies, build, run the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DDYNFILTER_WERROR=ON
cmake --build build
ctest --test-dir build --output-on-failure -j"$(nproc)"
