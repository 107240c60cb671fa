#!/usr/bin/env python3
"""Writes the configuration of an L7 gRPC proxy in front of several squalld replicas.

    proxy-config.py envoy --listen 127.0.0.1:50051 --upstream 127.0.0.1:50061 --upstream ... [--admin ADDR]
    proxy-config.py envoy --listen 0.0.0.0:8080 --dns --upstream squalld-pods:50051  (Kubernetes)
    proxy-config.py nginx --listen 127.0.0.1:50051 --upstream 127.0.0.1:50061 --upstream ... [--prefix DIR]

Both route a session's calls by the request metadata x-squall-session (consistent hashing, so a
session's calls, its creating call included, reach one replica) and spread calls without it.

Envoy (recommended): ring hash on the header; HTTP/2 upstream; active grpc.health.v1 checks every
second, so a replica still building its kernels or draining (it answers NOT_SERVING) gets no traffic and
its sessions' hash moves to the next replica on the ring; gRPC UNAVAILABLE answers retried on another
host.

nginx (simpler, Debian's package): `hash $squall_route consistent` over `grpc_pass`; only passive
failover (open-source nginx has no active gRPC health checks): a draining replica keeps its traffic
until its port closes, and clients' retries bridge the gap.

deploy/lb/envoy.yaml and deploy/lb/nginx.conf are this script's output for three replicas on one host;
deploy/k8s/overlays/two-tier/envoy.yaml its output for the headless Service of the replicas' pods
(--dns: every address the name resolves to is a host, re-resolved as pods come and go).
"""

from __future__ import annotations

import argparse
import sys
from typing import List, Tuple


def host_port(address: str) -> Tuple[str, int]:
    """HOST:PORT, or [IPV6]:PORT, as (host without brackets, port)."""
    host, _, port = address.rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    elif ":" in host:
        raise argparse.ArgumentTypeError(f"{address}: an IPv6 address is written [ADDRESS]:PORT")
    if not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"{address}: want HOST:PORT")
    return host, int(port)


def socket_address(address: str) -> str:
    """Envoy's socket_address of HOST:PORT, the host quoted: YAML would read [::1] as a list."""
    host, port = host_port(address)
    return f'{{socket_address: {{address: "{host}", port_value: {port}}}}}'


def envoy(listen: str, upstreams: List[str], admin: str, dns: bool) -> str:
    endpoints = "".join(
        f"""
              - endpoint: {{address: {socket_address(u)}}}"""
        for u in upstreams
    )
    dns_options = """
      dns_lookup_family: V4_PREFERRED
      dns_refresh_rate: 5s"""
    return f"""# Envoy in front of squalld replicas: written by deploy/lb/proxy-config.py.
admin:
  address: {socket_address(admin)}
static_resources:
  listeners:
    - name: grpc
      address: {socket_address(listen)}
      filter_chains:
        - filters:
            - name: envoy.filters.network.http_connection_manager
              typed_config:
                "@type": type.googleapis.com/envoy.extensions.filters.network.http_connection_manager.v3.HttpConnectionManager
                stat_prefix: squall
                codec_type: HTTP2
                # A stream may be quiet for up to an hour (an interactive client), as with
                # nginx (grpc_read_timeout 1h): longer than squalld's --stream-idle-timeout
                # (600 s by default), so squalld's limit is the one that applies. Envoy's
                # default, 5 minutes, would cut such a stream at the proxy.
                stream_idle_timeout: 3600s
                route_config:
                  name: squall
                  virtual_hosts:
                    - name: squalld
                      domains: ["*"]
                      routes:
                        - match: {{prefix: "/"}}
                          route:
                            cluster: squalld
                            timeout: 0s  # no limit on a call's duration (idle: above)
                            # A session's calls (x-squall-session) go to one replica; calls without it
                            # are spread (ring hash picks a random host when the header is absent).
                            hash_policy:
                              - header: {{header_name: x-squall-session}}
                            # UNAVAILABLE: a replica draining or handing a session over; retried on
                            # another host (the hash then walks to the next host on the ring).
                            retry_policy:
                              retry_on: unavailable,connect-failure,refused-stream,reset
                              num_retries: 3
                              retry_host_predicate:
                                - name: envoy.retry_host_predicates.previous_hosts
                                  typed_config:
                                    "@type": type.googleapis.com/envoy.extensions.retry.host.previous_hosts.v3.PreviousHostsPredicate
                              host_selection_retry_max_attempts: 3
                http_filters:
                  - name: envoy.filters.http.router
                    typed_config:
                      "@type": type.googleapis.com/envoy.extensions.filters.http.router.v3.Router
  clusters:
    - name: squalld
      type: {"STRICT_DNS" if dns else "STATIC"}{dns_options if dns else ""}
      lb_policy: RING_HASH
      typed_extension_protocol_options:
        envoy.extensions.upstreams.http.v3.HttpProtocolOptions:
          "@type": type.googleapis.com/envoy.extensions.upstreams.http.v3.HttpProtocolOptions
          explicit_http_config: {{http2_protocol_options: {{}}}}
      # grpc.health.v1 every second: NOT_SERVING (building kernels, draining) takes a replica out.
      # no_traffic_interval too: Envoy's default (60 s) applies until a cluster has had traffic, and
      # would leave a replica that was still starting at the first check out for a minute.
      health_checks:
        - timeout: 1s
          interval: 1s
          no_traffic_interval: 1s
          unhealthy_threshold: 1
          healthy_threshold: 1
          grpc_health_check: {{}}
      load_assignment:
        cluster_name: squalld
        endpoints:
          - lb_endpoints:{endpoints}
"""


def nginx(listen: str, upstreams: List[str], prefix: str) -> str:
    servers = "".join(f"\n        server {u} max_fails=1 fail_timeout=10s;" for u in upstreams)
    return f"""# nginx in front of squalld replicas: written by deploy/lb/proxy-config.py.
# Run: mkdir -p {prefix} && nginx -p {prefix} -c "$PWD/nginx.conf"
# (-c absolute: a relative one is read from the -p directory). The pid and temporary files go to
# {prefix} by absolute path (proxy-config.py --prefix); errors go to stderr; no root needed.
worker_processes 1;
pid {prefix}/nginx.pid;
error_log stderr warn;
events {{ worker_connections 1024; }}
http {{
    access_log off;
    client_body_temp_path {prefix}/client_body;
    proxy_temp_path {prefix}/proxy;
    fastcgi_temp_path {prefix}/fastcgi;
    uwsgi_temp_path {prefix}/uwsgi;
    scgi_temp_path {prefix}/scgi;
    # A session's calls hash on x-squall-session; calls without it on a per-request value, so they
    # spread over the replicas (an empty key would send them all to one).
    map $http_x_squall_session $squall_route {{
        "" $request_id;
        default $http_x_squall_session;
    }}
    upstream squalld {{
        hash $squall_route consistent;{servers}
    }}
    server {{
        listen {listen} http2;
        client_max_body_size 0;
        grpc_read_timeout 1h;
        grpc_send_timeout 1h;
        location / {{
            grpc_pass grpc://squalld;
            # Passive failover only: a replica that refuses connections is skipped.
            grpc_next_upstream error timeout;
        }}
    }}
}}
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("proxy", choices=["envoy", "nginx"])
    parser.add_argument("--listen", type=str, required=True, help="HOST:PORT the proxy serves")
    parser.add_argument("--upstream", action="append", required=True, help="a replica's HOST:PORT")
    parser.add_argument("--admin", default="127.0.0.1:9901", help="Envoy's admin HOST:PORT")
    parser.add_argument(
        "--prefix", default="/tmp/squall-nginx", help="nginx's directory for pid, temp files"
    )
    parser.add_argument("--dns", action="store_true", help="Envoy: upstreams are DNS names")
    args = parser.parse_args()
    for address in [args.listen, args.admin, *args.upstream]:
        host_port(address)
    if args.proxy == "envoy":
        sys.stdout.write(envoy(args.listen, args.upstream, args.admin, args.dns))
    else:
        sys.stdout.write(nginx(args.listen, args.upstream, args.prefix))


if __name__ == "__main__":
    main()
