#!/usr/bin/env bash
# Installs the Debian packages gazecast needs, when it can (root + apt-get),
# and otherwise prints the exact apt line and fails. Safe to run repeatedly:
# it only calls apt when a package is missing.
set -euo pipefail

# gcc/libc6-dev: linking; pkg-config + libudev-dev: serial ports (serialport);
# mesa-vulkan-drivers: the software Vulkan (lavapipe) the GPU tests run on;
# glmark2-data: the Stanford bunny (/usr/share/glmark2/models/bunny.obj);
# xvfb + libxcursor1 libxi6 libxkbcommon-x11-0: the viewer's window (winit,
# X11), which the tests open under a virtual X server; python3 +
# python3-venv: the virtual environments of the tests' outside peers
# (pylsl for the Lab Streaming Layer).
packages=(gcc libc6-dev pkg-config libudev-dev mesa-vulkan-drivers glmark2-data xvfb libxcursor1 libxi6 libxkbcommon-x11-0 python3 python3-venv)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

line="apt-get install -y --no-install-recommends ${missing[*]}"
if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "gazecast: installing missing system packages: ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  log=$(mktemp)
  # shellcheck disable=SC2086
  if ! { apt-get update -qq && apt-get install -y -qq --no-install-recommends ${missing[*]}; } >"$log" 2>&1; then
    cat "$log" >&2
    echo "gazecast: apt-get failed; try:  $line" >&2
    exit 1
  fi
  rm -f "$log"
else
  echo "gazecast: missing system packages: ${missing[*]}" >&2
  echo "gazecast: install them with:  sudo $line" >&2
  exit 1
fi
