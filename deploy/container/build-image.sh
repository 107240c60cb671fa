#!/usr/bin/env bash
# Builds squall's image from the checkout: the local Debian base first (make-base.sh) unless BASE is
# given, then deploy/container/Containerfile with the checkout's tracked and untracked-but-not-ignored
# files as the context (no build tree). Usage: build-image.sh [TAG] (default localhost/squall:latest).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
tag=${1:-localhost/squall:latest}
export CONTAINERS_CONF=${CONTAINERS_CONF:-$root/deploy/container/containers.conf}
base=${BASE:-localhost/debian:bookworm-slim}
[ -n "${BASE:-}" ] || "$root/deploy/container/make-base.sh" "$base"
context=$(mktemp -d)
trap 'rm -rf "$context"' EXIT
(cd "$root" && git ls-files -co --exclude-standard -z | xargs -0 tar -cf - --no-recursion) | tar -xf - -C "$context"
podman build --network host --build-arg BASE="$base" -f "$root/deploy/container/Containerfile" -t "$tag" "$context"
