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
context=$(mktemp -d) lists=$(mktemp -d)
trap 'rm -rf "$context" "$lists"' EXIT
# Tracked files deleted in the work tree are still listed by -c: left out (tar would fail on them).
# One tar reads the NUL-separated list (xargs could split it into several archives, and the
# extracting tar stops at the end of the first).
git -C "$root" ls-files -d -z > "$lists/deleted"
git -C "$root" ls-files -co --exclude-standard -z > "$lists/listed"
declare -A deleted=()
while IFS= read -r -d '' path; do deleted[$path]=1; done < "$lists/deleted"
files=()
while IFS= read -r -d '' path; do
  [ -n "${deleted[$path]+set}" ] || files+=("$path")
done < "$lists/listed"
printf '%s\0' "${files[@]}" | tar -C "$root" -cf - --no-recursion --null -T - | tar -xf - -C "$context"
podman build --network host --build-arg BASE="$base" -f "$root/deploy/container/Containerfile" -t "$tag" "$context"
