#!/usr/bin/env bash
# The container image, built and run as a user would: hadolint passes the Containerfile, .dockerignore
# leaves build trees out of a plain `docker build .`'s context; the image builds
# from the local Debian base (deploy/container/build-image.sh); two containers run read-only as the image's
# user, uid 10001 (host networking, each on its own 127.0.0.1 port) behind Envoy; health turns SERVING
# through the proxy; a GetTile through the proxy is bit for bit the host build's answer. Prints the image
# size and a cold start (empty kernel cache) to SERVING. Containers and processes are stopped by id / PID at
# exit.
# Usage: container_test.sh SOURCE_DIR SQUALLD SQUALL TOOLS_VENV WORK_DIR
set -euo pipefail
source_dir=$1 squalld=$2 squall=$3 tools=$4 work=$5
export CONTAINERS_CONF=$source_dir/deploy/container/containers.conf
image=localhost/squall:test
rm -rf "$work" && mkdir -p "$work"
containers=() pids=()
cleanup() {
  for c in "${containers[@]}"; do podman rm -f -t 5 "$c" >/dev/null 2>&1 || true; done
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
}
trap cleanup EXIT

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
wait_serving() {  # ADDRESS SECONDS
  local deadline=$((SECONDS + $2))
  until "$squall" --address "$1" --timeout 2 health >/dev/null 2>&1; do
    [ $SECONDS -lt $deadline ] || { echo "not SERVING at $1 within $2 s" >&2; return 1; }
    sleep 0.2
  done
}

"$tools/bin/hadolint" --failure-threshold error "$source_dir/deploy/container/Containerfile"
echo "hadolint: OK"

# `docker build .` / `podman build .` from the checkout: .dockerignore leaves the host's build trees and
# .git out of the context (a build/ would break the image's cmake -B build) and no tracked file.
ignore=$source_dir/.dockerignore
[ -f "$ignore" ] || { echo "no $ignore: a host build/ would go into the image's context" >&2; exit 1; }
for pattern in /build '/build-*' /.git; do
  grep -qxF -- "$pattern" "$ignore" || { echo "$ignore does not leave out $pattern" >&2; exit 1; }
done
left_out=$(git -C "$source_dir" ls-files -ci --exclude-from="$ignore")
[ -z "$left_out" ] || { echo "$ignore leaves out tracked files: $left_out" >&2; exit 1; }
echo ".dockerignore: OK"

if ! podman info >/dev/null 2>&1; then
  echo "SKIPPED: podman cannot run here: $(podman info 2>&1 | tail -1)"
  exit 77
fi

start=$SECONDS
"$source_dir/deploy/container/build-image.sh" "$image" > "$work/build.log" 2>&1 || { tail -50 "$work/build.log"; exit 1; }
echo "image built in $((SECONDS - start)) s: $(podman image inspect --format '{{.Size}}' "$image") bytes"

# Two replicas, read-only root, as the image's user (no --user), PoCL's cache on a tmpfs: the first one's
# start is cold.
addresses=()
for name in c0 c1; do
  port=$(free_port)
  started=$(date +%s.%N)
  containers+=("$(podman run -d --read-only --tmpfs /tmp --network host --name "squall-test-$name-$$" \
    "$image" --listen "127.0.0.1:$port" --metrics-listen 127.0.0.1:0 --replica-id "$name" --fft vkfft)")
  wait_serving "127.0.0.1:$port" 300
  echo "$name: SERVING $(python3 -c "import time; print(round(time.time() - $started, 2))") s after podman run (empty kernel cache)"
  addresses+=("127.0.0.1:$port")
done
user=$(podman exec "${containers[0]}" id -u)
[ "$user" = 10001 ] || { echo "the image runs as uid $user, not 10001" >&2; exit 1; }
# read-only even for root, so that a write is refused by the file system, not by a permission
if podman exec --user 0 "${containers[0]}" touch /x 2>/dev/null; then
  echo "the root file system is writable" >&2; exit 1
fi

proxy=127.0.0.1:$(free_port)
python3 "$source_dir/deploy/lb/proxy-config.py" envoy --listen "$proxy" --admin "127.0.0.1:$(free_port)" \
  --upstream "${addresses[0]}" --upstream "${addresses[1]}" > "$work/envoy.yaml"
setsid "$tools/bin/envoy" -c "$work/envoy.yaml" --log-level warn --base-id "$(free_port)" > "$work/envoy.log" 2>&1 &
pids+=($!)
wait_serving "$proxy" 60

host=127.0.0.1:$(free_port)
setsid "$squalld" --listen "$host" --fft vkfft > "$work/host.log" 2>&1 &
pids+=($!)
wait_serving "$host" 300

"$squall" --address "$proxy" ocean tile --grid 128 -o "$work/proxied.exr" > /dev/null
"$squall" --address "$host" ocean tile --grid 128 -o "$work/host.exr" > /dev/null
cmp "$work/proxied.exr" "$work/host.exr"
echo "GetTile through Envoy from the containers: bit for bit the host build's tile"
