// squalld's command-line flags. Every flag is --name=value or --name value, or the environment variable
// SQUALL_NAME (upper case, dashes as underscores: SQUALL_STATE_DIR for --state-dir), which a flag on the
// command line overrides; --help prints usage().
#pragma once

#include <functional>
#include <string>

#include "common/limits.h"
#include "common/log.h"
#include "fft/fft.h"
#include "runtime/runtime.h"

namespace squall::rpc {

// squalld's default limits: Limits' own, but --max-session-bytes 0 (half the device's global memory) and
// --memory-budget 0 (3/4 of the memory squalld may use): chosen at start-up.
inline Limits daemon_limits() {
  Limits limits;
  limits.max_session_bytes = 0;
  limits.memory_budget = 0;
  return limits;
}

struct DaemonOptions {
  std::string listen = "127.0.0.1:50051";   // --listen host:port (port 0 picks a free one)
  std::string port_file;                    // --port-file: write the bound port here once listening
  std::string metrics_listen;               // --metrics-listen host:port: Prometheus /metrics; empty: none
  RuntimeOptions runtime;                   // --device, --kernel-dir
  std::string cache_dir;                    // --cache-dir: POCL_CACHE_DIR (empty: the environment's, else XDG's)
  std::string fft = "auto";                 // --fft vkfft | clfft | fftw | auto (the fastest, measured at start-up)
  fft::FftwOptions fftw;                    // --fft-threads
  std::string fft_wisdom;                   // --fft-wisdom: a directory, "none", or "" for the kernel cache
  Limits limits = daemon_limits();          // --max-grid-cells, --max-streams, --max-sessions, --max-*-bytes
  double grace_seconds = 10;                // --grace-period: how long shutdown lets calls finish
  double drain_wait_seconds = 2;            // --drain-wait: answer UNAVAILABLE this long before closing
  double shutdown_bound_seconds = 5;        // --shutdown-bound: past the grace period, then the watchdog exits
  double keepalive_seconds = 60;            // --keepalive: server pings an idle connection this often
  int rpc_threads = 32;                     // --rpc-threads: gRPC threads kept waiting for calls
  double session_ttl_seconds = 600;         // --session-ttl: stateful sessions idle this long are evicted
  LogLevel log_level = LogLevel::Info;      // --log-level debug | info | warn | error
  std::string reflection = "auto";          // --reflection on | off | auto (on only when listening on loopback)
  std::string tls_cert, tls_key;            // --tls-cert, --tls-key: PEM files; both set: serve TLS only
  bool insecure = false;                    // --insecure: allow a non-loopback --listen without TLS or tokens
  std::string auth_tokens;                  // --auth-tokens: file of accepted bearer tokens; empty: no auth
  bool auth_exempt_health = true;           // --auth-exempt-health: health answers without a token
  std::string tls_client_ca;                // --tls-client-ca: PEM CA; set: require and verify client certificates
  unsigned tls_refresh_seconds = 60;        // --tls-refresh: how often the TLS files are re-read
  std::string replica_id;                   // --replica-id: this replica's name; empty: hostname:port
  std::string state_dir;                    // --state-dir: sessions are checkpointed here and resumed from here
  double checkpoint_interval_seconds = 30;  // --checkpoint-interval: live sessions written this often (0: at drain)
};

// --replica-id, else "<hostname>:<port of --listen>" (with port 0: "<hostname>:pid<pid>", unique too).
std::string replica_id(const DaemonOptions& options);

// Whether to serve gRPC server reflection: --reflection on / off, or with auto only when --listen is a
// loopback address (127.0.0.0/8, [::1], localhost) and no --auth-tokens are required, so a daemon exposed
// to a network, or one that checks tokens, does not list its API to anyone who asks.
bool reflection_enabled(const DaemonOptions& options);

// Returns false with a message in *error (naming the flag or the variable) on an unknown flag or a bad
// value. Sets *help when --help is given. `environment` looks variables up (getenv in squalld).
using Environment = std::function<const char*(const char*)>;
bool parse_options(int argc, char** argv, DaemonOptions* options, bool* help, std::string* error,
                   const Environment& environment);
bool parse_options(int argc, char** argv, DaemonOptions* options, bool* help, std::string* error);
std::string usage();

}  // namespace squall::rpc
