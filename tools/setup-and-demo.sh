#!/usr/bin/env bash
# One command on a fresh Debian 12: install dependencies, build (Release), run the demo:
# describe the human figure, filter a kinematic squat into a physically consistent one, then
# a CMU walk in the paper mode and in the QP mode, and the walk on a Unitree G1.
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
# A second robot: the Unitree G1 (example-robot-data wheel). The walk retargeted in the IK
# mode (scaled to the G1's leg length, stance feet held on the ground), filtered in the QP
# mode; the task point's link is chosen from the model (its trunk).
if G1="$(tools/g1-urdf.sh)"; then
  ./build/tools/bvh2ref/dynfilter-bvh2ref data/mocap/cmu/131_01_start_walk_stop.bvh \
      --mapping data/mocap/cmu/mappings/131_01_g1.yaml --model "$G1" -o build/g1_walk_reference.csv
  ./build/tools/offline/dynfilter-offline build/g1_walk_reference.csv --model "$G1" --mode qp \
      -o build/g1_walk_filtered_qp.csv
fi
