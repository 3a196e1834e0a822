#!/usr/bin/env bash
# Installs everything dynfilter builds and tests with, from Debian 12 packages.
# Idempotent; uses sudo when not run as root.
# Also makes a Python venv (default build/venv, or $DYNFILTER_LCM_VENV) holding the `lcm`
# wheel: its lcm-spy starts on Java 17 (Debian's does not), and its lcm.jar and Python
# binding are what the Java and Python message types are used with (README "LCM messages"),
# and matplotlib and numpy for tools/plot_lcm_log.py.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
packages=(
  build-essential cmake ninja-build pkg-config python3 python3-numpy
  libeigen3-dev
  libdart-dev libdart-collision-bullet-dev libbullet-dev libassimp-dev
  libdart-utils-urdf-dev     # examples/dart_attach: the user's own DartLoader
  libode-dev
  liburdfdom-dev liburdfdom-headers-dev libconsole-bridge-dev libtinyxml2-dev
  liblcm-dev liblcm-bin libglib2.0-dev default-jdk-headless python3-venv
  libgtest-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev libyaml-cpp-dev
  clang libclang-rt-14-dev   # fuzz/: clang 14 with libFuzzer and the sanitizer runtimes
)
# Prints those of the given Debian packages that are not installed, one a line.
not_installed() {
  local p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}
mapfile -t missing < <(not_installed "${packages[@]}")
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The lcm wheel in a venv (pip refuses to install into Debian's system Python, PEP 668).
LCM_WHEEL_VERSION=1.5.3
repo="$(cd "$(dirname "$0")/.." && pwd)"
venv="${DYNFILTER_LCM_VENV:-$repo/build/venv}"
if ! "$venv/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('lcm') != '$LCM_WHEEL_VERSION')" 2>/dev/null; then
  echo "installing the lcm $LCM_WHEEL_VERSION wheel into $venv"
  python=/usr/bin/python3
  [ -x "$python" ] || python="$(command -v python3)"
  # Only the Java/Python tooling needs it (the C++ build and tests do not): warn, go on.
  if ! { "$python" -m venv "$venv" &&
         "$venv/bin/python" -m pip install -q --disable-pip-version-check "lcm==$LCM_WHEEL_VERSION"; }; then
    echo "warning: could not install the lcm wheel into $venv: no dynfilter_lcmtypes.jar," \
         "no tools/lcm-spy.sh (README, \"LCM messages\")" >&2
  fi
fi
# numpy and matplotlib in the same venv, for tools/plot_lcm_log.py (README "Plotting a log").
MATPLOTLIB_VERSION=3.8.4
NUMPY_VERSION=1.26.4
if [ -x "$venv/bin/python" ] &&
   ! "$venv/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('matplotlib') != '$MATPLOTLIB_VERSION' or m.version('numpy') != '$NUMPY_VERSION')" 2>/dev/null; then
  echo "installing matplotlib $MATPLOTLIB_VERSION and numpy $NUMPY_VERSION into $venv"
  # Only the log plotter needs them: warn, go on.
  if ! "$venv/bin/python" -m pip install -q --disable-pip-version-check \
         "matplotlib==$MATPLOTLIB_VERSION" "numpy==$NUMPY_VERSION"; then
    echo "warning: could not install matplotlib and numpy into $venv: no tools/plot_lcm_log.py" \
         "(README, \"Plotting a log\")" >&2
  fi
fi

# ProxQP (proxsuite), the QP mode's solver: header-only C++, shipped as a CMake package in
# its PyPI wheel (under site-packages/cmeel.prefix). The C++ build needs it: fail loudly.
PROXSUITE_VERSION=0.7.2
if ! "$venv/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('proxsuite') != '$PROXSUITE_VERSION')" 2>/dev/null; then
  echo "installing the proxsuite $PROXSUITE_VERSION wheel (C++ headers + CMake package) into $venv"
  [ -x "$venv/bin/python" ] || /usr/bin/python3 -m venv "$venv"
  # --no-deps: only the C++ headers are used, not its Python module (which needs numpy/scipy).
  "$venv/bin/python" -m pip install -q --disable-pip-version-check --no-deps \
    "proxsuite==$PROXSUITE_VERSION" || {
    echo "error: could not install proxsuite $PROXSUITE_VERSION into $venv (needed by the build)" >&2
    exit 1
  }
fi

# A second robot for the demo and the results report: the Unitree G1 (29 DoF) of the
# example-robot-data wheel (BSD-3-Clause robot description from Unitree, packaged by
# LAAS-CNRS et al., BSD-2-Clause): URDFs and meshes only, no Python dependencies needed.
# tools/g1-urdf.sh prints the G1 URDF's path. Only the G1 demo needs it: warn, go on.
EXAMPLE_ROBOT_DATA_VERSION=6.0.0
if [ -x "$venv/bin/python" ] &&
   ! "$venv/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('example-robot-data') != '$EXAMPLE_ROBOT_DATA_VERSION')" 2>/dev/null; then
  echo "installing the example-robot-data $EXAMPLE_ROBOT_DATA_VERSION wheel (robot URDFs) into $venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check --no-deps \
    "example-robot-data==$EXAMPLE_ROBOT_DATA_VERSION" ||
    echo "warning: could not install example-robot-data into $venv: no G1 demo" >&2
fi

# The Python package dynfilter (python/, README "Python"): pybind11 and the Python headers
# for the native module; pytest (its ctest suites), PyYAML (manifests), tqdm (progress) and
# Ray (dynfilter.batch --ray-address) in the venv. Only the Python package needs them: warn, go on.
python_packages=(pybind11-dev python3-dev)
mapfile -t missing < <(not_installed "${python_packages[@]}")
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" ||
    echo "warning: could not install ${missing[*]}: no Python bindings (README, \"Python\")" >&2
fi
PYTHON_WHEELS=(pytest==9.2.0 PyYAML==6.0.4 tqdm==4.70.1 ray==2.60.0)
if [ -x "$venv/bin/python" ] && ! "$venv/bin/python" - "${PYTHON_WHEELS[@]}" <<'PY' 2>/dev/null
import importlib.metadata as m, sys
sys.exit(any(m.version(n) != v for n, v in (w.split("==") for w in sys.argv[1:])))
PY
then
  echo "installing ${PYTHON_WHEELS[*]} into $venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check "${PYTHON_WHEELS[@]}" ||
    echo "warning: could not install ${PYTHON_WHEELS[*]} into $venv: no Python tests or" \
         "batch on Ray (README, \"Python\")" >&2
fi
