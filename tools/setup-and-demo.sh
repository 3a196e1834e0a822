#!/usr/bin/env bash
# One command on a fresh Debian 12: install dependencies, build (Release), run the demo.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build
./build/tools/model_info/dynfilter-model-info --joints
