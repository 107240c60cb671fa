#!/usr/bin/env bash
# Installs those of the Debian packages given as arguments that are not installed yet (apt-get as root,
# else through sudo); prints what it did under the caller's name ($APT_INSTALL_NAME).
# Usage: apt-install.sh PACKAGE...
set -euo pipefail
name=${APT_INSTALL_NAME:-apt-install}
missing=()
for p in "$@"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "$name: all $# packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "$name: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
