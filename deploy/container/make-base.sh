#!/usr/bin/env bash
# Makes the image's base, Debian 12 minbase, from Debian's packages and imports it into podman as
# localhost/debian:bookworm-slim, so the image builds where no container registry can be reached.
# DEBIAN_MIRROR / DEBIAN_SECURITY_MIRROR pick the mirrors. Idempotent: nothing to do when the base exists.
# Usage: make-base.sh [TAG]
set -euo pipefail
tag=${1:-localhost/debian:bookworm-slim}
export CONTAINERS_CONF=${CONTAINERS_CONF:-$(cd "$(dirname "$0")" && pwd)/containers.conf}
if podman image exists "$tag"; then
  echo "make-base: $tag exists"
  exit 0
fi
mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
security=${DEBIAN_SECURITY_MIRROR:-http://deb.debian.org/debian-security}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The suites a Debian 12 host uses, so the image gets the same package versions (and security fixes).
# Like Debian's -slim images: no manual pages, documentation (but the copyright files) or translations,
# in the base and in every package installed on it later (the options stay in /etc/dpkg/dpkg.cfg.d).
slim=(--dpkgopt='path-exclude=/usr/share/man/*' --dpkgopt='path-exclude=/usr/share/doc/*'
  --dpkgopt='path-include=/usr/share/doc/*/copyright' --dpkgopt='path-exclude=/usr/share/locale/*'
  --dpkgopt='path-exclude=/usr/share/info/*')
mmdebstrap --variant=minbase --quiet "${slim[@]}" bookworm "$work/base.tar" "deb $mirror bookworm main" \
  "deb $mirror bookworm-updates main" "deb $security bookworm-security main"
podman import --quiet "$work/base.tar" "$tag" >/dev/null
echo "make-base: $tag from $mirror and $security ($(podman image inspect --format '{{.Size}}' "$tag") bytes)"
