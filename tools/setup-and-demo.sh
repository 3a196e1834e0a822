#!/usr/bin/env bash
# One command on a fresh Debian 12: install dependencies, build (Release), run the demo:
# describe the human figure, filter a kinematic squat into a physically consistent one, then
# a CMU walk in the paper mode and in the QP mode.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build
./build/tools/model_info/dynfilter-model-info
./build/tools/offline/dynfilter-offline data/squat_reference.csv -o build/squat_filtered.csv
# Real motion capture: the CMU walk, retargeted to the figure and filtered.
./build/tools/bvh2ref/dynfilter-bvh2ref data/mocap/cmu/131_01_start_walk_stop.bvh \
    --mapping data/mocap/cmu/mappings/131_01.yaml -o build/walk_reference.csv
./build/tools/offline/dynfilter-offline build/walk_reference.csv -o build/walk_filtered.csv
# The same walk in the QP mode: no pulling contact, friction cones, CoP in the soles,
# torques within the URDF limits (compare the two summaries' contact force lines).
./build/tools/offline/dynfilter-offline build/walk_reference.csv -o build/walk_filtered_qp.csv --mode qp
