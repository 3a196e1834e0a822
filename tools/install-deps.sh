#!/usr/bin/env bash
# Installs everything dynfilter builds and tests with, from Debian 12 packages.
# Idempotent; uses sudo when not run as root.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
packages=(
  build-essential cmake ninja-build pkg-config python3 python3-numpy
  libeigen3-dev
  libdart-dev libdart-collision-bullet-dev libbullet-dev
  libode-dev
  liburdfdom-dev liburdfdom-headers-dev libconsole-bridge-dev libtinyxml2-dev
  liblcm-dev libglib2.0-dev
  libgtest-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev libyaml-cpp-dev
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
