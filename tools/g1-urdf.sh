#!/usr/bin/env bash
# Prints the path of the Unitree G1 URDF (29 DoF) installed by tools/install-deps.sh from
# the example-robot-data wheel into the venv (default build/venv, or $DYNFILTER_LCM_VENV).
# Exits 1 with a message when it is not installed.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
venv="${DYNFILTER_LCM_VENV:-$repo/build/venv}"
for f in "$venv"/lib/python3*/site-packages/cmeel.prefix/share/example-robot-data/robots/g1_description/urdf/g1_29dof_rev_1_0.urdf; do
  if [ -f "$f" ]; then echo "$f"; exit 0; fi
done
echo "g1-urdf.sh: the G1 URDF is not in $venv (run tools/install-deps.sh)" >&2
exit 1
