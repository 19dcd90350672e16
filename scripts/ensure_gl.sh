#!/usr/bin/env bash
# Make sure Mesa's EGL + llvmpipe are installed (vislod renders headless on the CPU).
# As root, installs them with apt; otherwise prints the exact command and fails.
set -euo pipefail
PKGS="libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri"

have_gl() {
  ldconfig -p | grep -q 'libEGL.so.1 ' &&
    ldconfig -p | grep -q 'libEGL_mesa.so.0 ' &&
    ldconfig -p | grep -q 'libGL.so.1 ' &&
    compgen -G '/usr/lib/*/dri/swrast_dri.so' >/dev/null
}

have_gl && exit 0
if [ "$(id -u)" = 0 ]; then
  echo "Installing Mesa EGL/llvmpipe: apt-get install -y $PKGS"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends $PKGS >/dev/null
  have_gl && exit 0
  echo "error: $PKGS installed but libEGL_mesa/swrast_dri still not found" >&2
  exit 1
fi
echo "error: Mesa's EGL and llvmpipe are missing. Install them with:" >&2
echo "  sudo apt-get install -y $PKGS" >&2
exit 1
