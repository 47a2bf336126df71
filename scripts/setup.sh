#!/usr/bin/env bash
# Installs every Debian package ffdkit needs. Idempotent: re-running installs nothing new.
set -euo pipefail
PKGS=(build-essential cmake pkg-config
      liblapacke-dev libopenblas-dev libcjson-dev
      clang libclang-rt-14-dev
      libqhull-dev libsuitesparse-dev)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "setup: installing ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
