#!/usr/bin/env bash
# deploy/lb/envoy.yaml and nginx.conf are exactly what deploy/lb/proxy-config.py writes for three replicas
# (no drift between the example and the generator the tests use), as is the Kubernetes two-tier overlay's
# envoy.yaml for the pods' headless Service, and Envoy and nginx accept them.
# Usage: check_lb_config.sh SOURCE_DIR TOOLS_VENV WORK_DIR
set -euo pipefail
source_dir=$1 tools=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
nginx=/usr/sbin/nginx  # not on a non-root user's PATH on Debian
for tool in "$tools/bin/envoy" "$nginx"; do
  [ -x "$tool" ] || { echo "missing $tool: run deploy/install-deploy-tools.sh" >&2; exit 1; }
done
upstreams=(--upstream 127.0.0.1:50061 --upstream 127.0.0.1:50062 --upstream 127.0.0.1:50063)
generate() { python3 "$source_dir/deploy/lb/proxy-config.py" "$@" --listen 127.0.0.1:50051 "${upstreams[@]}"; }
generate envoy > "$work/envoy.yaml"
generate nginx > "$work/nginx.conf"
diff -u "$source_dir/deploy/lb/envoy.yaml" "$work/envoy.yaml"
diff -u "$source_dir/deploy/lb/nginx.conf" "$work/nginx.conf"
python3 "$source_dir/deploy/lb/proxy-config.py" envoy --listen 0.0.0.0:8080 --dns --upstream squalld-pods:50051 \
  --admin 127.0.0.1:9901 > "$work/two-tier-envoy.yaml"
diff -u "$source_dir/deploy/k8s/overlays/two-tier/envoy.yaml" "$work/two-tier-envoy.yaml"
# A quiet stream lasts as long through Envoy as through nginx (grpc_read_timeout 1h): Envoy's default
# stream_idle_timeout (5 minutes) would cut it.
grep -q '^ *grpc_read_timeout 1h;$' "$work/nginx.conf" || { echo "nginx.conf: no grpc_read_timeout 1h" >&2; exit 1; }
for config in "$work/envoy.yaml" "$work/two-tier-envoy.yaml"; do
  grep -q '^ *stream_idle_timeout: 3600s$' "$config" || { echo "$config: no stream_idle_timeout: 3600s" >&2; exit 1; }
done
"$tools/bin/envoy" --mode validate -c "$work/envoy.yaml" --log-level error
mkdir -p /tmp/squall-nginx  # the example's prefix
"$nginx" -t -p /tmp/squall-nginx -c "$work/nginx.conf"
# IPv6 loopback, written [::1]:PORT: Envoy takes the address unbracketed and quoted (YAML would read [::1] as a
# list), nginx as given.
v6=(--listen "[::1]:50051" --upstream "[::1]:50061" --upstream "[::1]:50062" --admin "[::1]:9901")
python3 "$source_dir/deploy/lb/proxy-config.py" envoy "${v6[@]}" > "$work/envoy-v6.yaml"
python3 "$source_dir/deploy/lb/proxy-config.py" nginx "${v6[@]}" > "$work/nginx-v6.conf"
grep -q 'address: "::1", port_value: 50061' "$work/envoy-v6.yaml" || { echo "envoy-v6.yaml: no ::1 upstream" >&2; exit 1; }
"$tools/bin/envoy" --mode validate -c "$work/envoy-v6.yaml" --log-level error
"$nginx" -t -p /tmp/squall-nginx -c "$work/nginx-v6.conf"
if python3 "$source_dir/deploy/lb/proxy-config.py" envoy --listen ::1:50051 --upstream ::1:50061 2>/dev/null; then
  echo "proxy-config.py took an IPv6 address without brackets" >&2; exit 1
fi
# A broken configuration must fail the same checks.
sed 's/lb_policy: RING_HASH/lb_policy: RING_HASHH/' "$work/envoy.yaml" > "$work/broken.yaml"
if "$tools/bin/envoy" --mode validate -c "$work/broken.yaml" --log-level critical >/dev/null 2>&1; then
  echo "envoy accepted a broken configuration" >&2; exit 1
fi
echo "lb configurations: OK"
