#!/usr/bin/env bash
# Install the benchmark peers with apt:
#   - POV-Ray 3.7 (Debian package `povray`), for the renderer benchmark;
#   - Singular (Debian package `singular`), for bench/singular/ (algebra
#     reference data and timings).
# Idempotent: does nothing when it is already installed.
# Needs root (or sudo) on Debian/Ubuntu.
set -euo pipefail

PKGS=(povray singular)

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-peers: already installed: ${PKGS[*]}"
  exit 0
fi

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
