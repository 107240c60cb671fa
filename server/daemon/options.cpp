#include "daemon/options.h"

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <utility>
#include <vector>
#include <stdexcept>

#include "common/validate.h"

namespace squall::rpc {
namespace {

using Setter = std::function<void(const std::string&)>;

// A number as the flags are written: decimal digits, a point and an exponent (1.5, 4e11); no hex, inf,
// nan or empty text. -0 is 0.
double decimal(const std::string& text, const std::string& rule) {
  const std::optional<double> v = validate::decimal(text);
  if (!v) throw std::invalid_argument(rule);
  return *v + 0.0;
}

uint64_t positive_integer(const std::string& text) {
  const char* rule = "must be an integer >= 1";
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) throw std::invalid_argument(rule);
  long long v = std::stoll(text);  // std::out_of_range past 2^63 - 1
  if (v < 1) throw std::invalid_argument(rule);
  return static_cast<uint64_t>(v);
}

// A whole number in [1, max]; `why` says what sets max, where that is not plain.
uint64_t integer_at_most(const std::string& text, uint64_t max, const std::string& why = "") {
  const uint64_t n = positive_integer(text);
  if (n > max) throw std::invalid_argument("must be 1 to " + std::to_string(max) + why);
  return n;
}

// A count written as an integer or in the exponent notation of the defaults (--max-render-samples 4e11).
double positive_count(const std::string& text) {
  const double v = decimal(text, "must be a whole number >= 1 (e.g. 4e11)");
  if (!std::isfinite(v) || v < 1 || v != std::floor(v))
    throw std::invalid_argument("must be a whole number >= 1 (e.g. 4e11)");
  return v;
}

// The longest duration a flag takes, s (31 years): a deadline that far ahead still fits the clocks' 64-bit
// nanoseconds.
constexpr double kMaxSeconds = 1e9;

double seconds_or_zero(const std::string& text) {
  const std::string rule = "must be a number of seconds in [0, " + validate::number(kMaxSeconds) + "]";
  const double v = decimal(text, rule);
  if (!(v >= 0 && v <= kMaxSeconds)) throw std::invalid_argument(rule);
  return v;
}

// 0 (no limit), or at least 0.1 s: the stream watch looks four times per timeout.
double idle_seconds(const std::string& text) {
  const double v = seconds_or_zero(text);
  if (v > 0 && v < 0.1)
    throw std::invalid_argument("must be 0 (no limit) or a number of seconds in [0.1, " +
                                validate::number(kMaxSeconds) + "]");
  return v;
}

bool on_or_off(const std::string& v) {
  if (v == "on" || v == "true" || v == "1") return true;
  if (v == "off" || v == "false" || v == "0") return false;
  throw std::invalid_argument("must be on or off");
}

// --rpc-threads' and --fft-threads' bound.
constexpr uint64_t kMaxThreads = 1024;
// --max-calls' bound: a running call holds a thread.
constexpr uint64_t kMaxCalls = 16384;

// --max-grid-cells' own bound: 2^26 cells (8192^2) times 32 planes is within a 32-bit index.
constexpr uint64_t kMaxGridCellsFlag = uint64_t(1) << 26;

// Seconds in (0, max], or in [min, max] when min > 0.
double positive_seconds(const std::string& text, double max = kMaxSeconds, double min = 0) {
  const std::string rule = "must be a number of seconds in " + std::string(min > 0 ? "[" : "(") +
                           validate::number(min) + ", " + validate::number(max) + "]";
  const double v = decimal(text, rule);
  if (!(v > 0 && v >= min && v <= max)) throw std::invalid_argument(rule);
  return v;
}

std::map<std::string, Setter> setters(DaemonOptions* o) {
  return {
      {"listen", [o](const std::string& v) { o->listen = v; }},
      {"port-file", [o](const std::string& v) { o->port_file = v; }},
      {"metrics-listen", [o](const std::string& v) { o->metrics_listen = v; }},
      {"device", [o](const std::string& v) { o->runtime.device = v; }},
      {"kernel-dir", [o](const std::string& v) { o->runtime.kernel_dir = v; }},
      {"device-queues", [o](const std::string& v) { o->runtime.queues = size_t(integer_at_most(v, 16)); }},
      {"cpu-buffers",
       [o](const std::string& v) {
         if (v != "host" && v != "device") throw std::invalid_argument("must be host or device");
         o->runtime.host_buffers_on_cpu = v == "host";
       }},
      {"cache-dir", [o](const std::string& v) { o->cache_dir = v; }},
      {"fft",
       [o](const std::string& v) {
         if (v != "auto" && v != "vkfft" && v != "clfft" && v != "fftw")
           throw std::invalid_argument("must be auto, vkfft, clfft or fftw");
         o->fft = v;
       }},
      {"fft-threads", [o](const std::string& v) { o->fftw.threads = int(integer_at_most(v, kMaxThreads)); }},
      {"fft-wisdom", [o](const std::string& v) { o->fft_wisdom = v; }},
      {"max-grid-cells",
       [o](const std::string& v) {
         o->limits.max_grid_cells = integer_at_most(
             v, kMaxGridCellsFlag, " (the kernels index a grid's planes, up to 32 in a buffer, with 32-bit integers)");
       }},
      {"max-streams", [o](const std::string& v) { o->limits.max_streams = uint32_t(integer_at_most(v, UINT32_MAX)); }},
      {"max-calls", [o](const std::string& v) { o->limits.max_calls = uint32_t(integer_at_most(v, kMaxCalls)); }},
      {"max-streams-per-client",
       [o](const std::string& v) { o->limits.max_streams_per_client = uint32_t(integer_at_most(v, UINT32_MAX)); }},
      {"max-sessions",
       [o](const std::string& v) { o->limits.max_sessions = uint32_t(integer_at_most(v, UINT32_MAX)); }},
      {"max-sessions-per-client",
       [o](const std::string& v) { o->limits.max_sessions_per_client = uint32_t(integer_at_most(v, UINT32_MAX)); }},
      {"stream-idle-timeout", [o](const std::string& v) { o->limits.stream_idle_seconds = idle_seconds(v); }},
      {"memory-budget", [o](const std::string& v) { o->limits.memory_budget = positive_integer(v); }},
      {"max-message-bytes",
       [o](const std::string& v) {
         o->limits.max_message_bytes = integer_at_most(v, INT32_MAX, " (gRPC's largest message)");
       }},
      {"max-session-bytes", [o](const std::string& v) { o->limits.max_session_bytes = positive_integer(v); }},
      {"max-render-samples", [o](const std::string& v) { o->limits.max_render_samples = positive_count(v); }},
      {"max-advection-samples", [o](const std::string& v) { o->limits.max_advection_samples = positive_count(v); }},
      {"max-bake-work", [o](const std::string& v) { o->limits.max_bake_work = positive_count(v); }},
      {"grace-period", [o](const std::string& v) { o->grace_seconds = positive_seconds(v); }},
      {"drain-wait", [o](const std::string& v) { o->drain_wait_seconds = seconds_or_zero(v); }},
      {"shutdown-bound", [o](const std::string& v) { o->shutdown_bound_seconds = positive_seconds(v); }},
      // gRPC takes the interval in int milliseconds, and a ping every few milliseconds is a flood
      {"keepalive", [o](const std::string& v) { o->keepalive_seconds = positive_seconds(v, 1e6, 0.1); }},
      {"rpc-threads", [o](const std::string& v) { o->rpc_threads = int(integer_at_most(v, kMaxThreads)); }},
      {"session-ttl", [o](const std::string& v) { o->session_ttl_seconds = positive_seconds(v); }},
      {"profile-kernels", [o](const std::string& v) { o->runtime.profile_kernels = on_or_off(v); }},
      {"reflection",
       [o](const std::string& v) {
         if (v != "on" && v != "off" && v != "auto") throw std::invalid_argument("must be on, off or auto");
         o->reflection = v;
       }},
      {"auth-tokens", [o](const std::string& v) { o->auth_tokens = v; }},
      {"insecure", [o](const std::string& v) { o->insecure = on_or_off(v); }},
      {"auth-exempt-health", [o](const std::string& v) { o->auth_exempt_health = on_or_off(v); }},
      {"tls-cert", [o](const std::string& v) { o->tls_cert = v; }},
      {"tls-key", [o](const std::string& v) { o->tls_key = v; }},
      {"tls-client-ca", [o](const std::string& v) { o->tls_client_ca = v; }},
      {"tls-refresh", [o](const std::string& v) { o->tls_refresh_seconds = unsigned(integer_at_most(v, 86400)); }},
      {"replica-id",
       [o](const std::string& v) {
         if (v.empty() || v.size() > 128) throw std::invalid_argument("must be 1 to 128 characters");
         // Sent as the x-squall-replica metadata value on every call, which gRPC takes as printable ASCII only
         // (anything else aborts the process), and logged word by word.
         for (unsigned char c : v)
           if (c <= 0x20 || c > 0x7e) throw std::invalid_argument("must be printable ASCII, with no spaces");
         o->replica_id = v;
       }},
      {"state-dir", [o](const std::string& v) { o->state_dir = v; }},
      {"checkpoint-interval", [o](const std::string& v) { o->checkpoint_interval_seconds = seconds_or_zero(v); }},
      {"log-level",
       [o](const std::string& v) {
         if (!parse_log_level(v, &o->log_level)) throw std::invalid_argument("must be debug, info, warn or error");
       }},
  };
}

// --listen is 127.0.0.0/8, [::1] or localhost.
bool listens_on_loopback(const DaemonOptions& options) {
  const std::string& a = options.listen;
  return a.rfind("127.", 0) == 0 || a.rfind("[::1]:", 0) == 0 || a.rfind("localhost:", 0) == 0;
}

// The variable that sets --name: SQUALL_NAME, dashes as underscores.
std::string variable_of(const std::string& name) {
  std::string variable = "SQUALL_";
  for (char c : name) variable += c == '-' ? '_' : char(std::toupper(static_cast<unsigned char>(c)));
  return variable;
}

// Applies `value` to the flag's setter; false with *error naming `source` ("--name" or "SQUALL_NAME").
bool apply(const Setter& set, const std::string& source, const std::string& value, std::string* error) {
  try {
    set(value);
    return true;
  } catch (const std::exception& e) {
    *error = source + " " + value + ": " + (dynamic_cast<const std::invalid_argument*>(&e) ? e.what() : "out of range");
    return false;
  }
}

// The command line's flags as (name, value) pairs, in order; false with *error on a malformed or unknown one.
bool read_command_line(int argc, char** argv, const std::map<std::string, Setter>& table,
                       std::vector<std::pair<std::string, std::string>>* flags, bool* help, std::string* error) {
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      *help = true;
      return true;
    }
    if (arg.rfind("--", 0) != 0) {
      *error = "unexpected argument " + arg;
      return false;
    }
    std::string name = arg.substr(2), value;
    if (auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    } else if (i + 1 < argc) {
      value = argv[++i];
    } else {
      *error = "--" + name + " needs a value";
      return false;
    }
    if (!table.count(name)) {
      *error = "unknown flag --" + name + " (see --help)";
      return false;
    }
    flags->emplace_back(name, value);
  }
  return true;
}

}  // namespace

std::string replica_id(const DaemonOptions& options) {
  if (!options.replica_id.empty()) return options.replica_id;
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  const std::string port = options.listen.substr(options.listen.rfind(':') + 1);
  return std::string(host) + ":" + (port == "0" ? "pid" + std::to_string(getpid()) : port);
}

bool parse_options(int argc, char** argv, DaemonOptions* options, bool* help, std::string* error,
                   const Environment& environment) {
  auto table = setters(options);
  *help = false;
  std::vector<std::pair<std::string, std::string>> flags;
  if (!read_command_line(argc, argv, table, &flags, help, error)) return false;
  if (*help) return true;
  std::set<std::string> given;
  for (const auto& flag : flags) given.insert(flag.first);
  for (const auto& [name, set] : table) {  // the variables of the flags the command line does not give
    const std::string variable = variable_of(name);
    const char* value = environment(variable.c_str());
    if (value && !given.count(name) && !apply(set, variable, value, error)) return false;
  }
  for (const auto& [name, value] : flags)
    if (!apply(table.at(name), "--" + name, value, error)) return false;
  if (options->tls_cert.empty() != options->tls_key.empty()) {
    *error = "--tls-cert and --tls-key go together";
    return false;
  }
  if (!options->tls_client_ca.empty() && options->tls_cert.empty()) {
    *error = "--tls-client-ca needs --tls-cert and --tls-key";
    return false;
  }
  if (options->reflection == "on" && !options->auth_tokens.empty()) {  // reflection follows auth: it cannot
    *error =
        "--reflection on with --auth-tokens: gRPC's reflection service does not check tokens, so it would "
        "describe the API to callers without one; use --reflection auto (off with tokens) or off";
    return false;
  }
  if (!listens_on_loopback(*options) && options->tls_cert.empty() && options->auth_tokens.empty() &&
      !options->insecure) {
    *error = "--listen " + options->listen +
             " is not a loopback address: anyone who reaches it could use squalld; give --tls-cert/--tls-key "
             "and/or --auth-tokens, or --insecure to serve it in plaintext to everyone anyway";
    return false;
  }
  return true;
}

bool reflection_enabled(const DaemonOptions& options) {
  if (options.reflection != "auto") return options.reflection == "on";
  return listens_on_loopback(options) && options.auth_tokens.empty();
}

std::string usage() {
  DaemonOptions d;
  return "usage: squalld [flags]   (each flag may also be set as SQUALL_FLAG_NAME in the environment)\n"
         "  --listen HOST:PORT        address to serve on (default " +
         d.listen +
         "; port 0 picks a free port)\n"
         "  --port-file PATH          write the bound port to PATH once listening\n"
         "  --metrics-listen HOST:PORT  serve Prometheus metrics at http://HOST:PORT/metrics (default: none)\n"
         "  --device SPEC             auto | cpu | gpu | substring of the platform or device name (default auto:\n"
         "                            the first GPU, else the PoCL CPU device)\n"
         "  --device-queues N         requests on the device at once, each on its own in-order queue, 1..16\n"
         "                            (default 3; 1 serializes them; from 3 on, while much shorter work is\n"
         "                            about, longer work holds about half of them at most)\n"
         "  --cpu-buffers host|device  on a CPU device, make buffers over host memory, which reads and writes\n"
         "                            reach with no command (default host), or as a GPU's are (device: tests\n"
         "                            the paths a GPU takes)\n"
         "  --fft NAME                auto | vkfft | clfft | fftw (default auto: the fastest, timed at start-up;\n"
         "                            fftw, on the host, only for CPU devices)\n"
         "  --fft-threads N           FFTW's threads per transform of 512^2 cells or more (default: the\n"
         "                            device's compute units, at most the cgroup CPU quota rounded up;\n"
         "                            smaller ones run on one)\n"
         "  --fft-wisdom DIR|none     where FFTW's measured plans are kept for the next start (default: the\n"
         "                            kernel cache)\n"
         "  --kernel-dir DIR          load OpenCL sources from DIR instead of the embedded copy (development)\n"
         "  --cache-dir DIR           PoCL kernel cache (default $POCL_CACHE_DIR, else $XDG_CACHE_HOME/squall/pocl,\n"
         "                            else ~/.cache/squall/pocl)\n"
         "  --max-grid-cells N        cells of one field, at most 67108864 (default " +
         std::to_string(d.limits.max_grid_cells) +
         ")\n"
         "  --max-streams N           concurrent streaming calls (default " +
         std::to_string(d.limits.max_streams) +
         ")\n"
         "  --max-calls N             unary calls of the capabilities running at once, 1..16384 (default " +
         std::to_string(d.limits.max_calls) +
         "); health\n"
         "                            checks are not counted\n"
         "  --max-streams-per-client N  of those, one client's (its address without the port; default: no\n"
         "                            limit of its own)\n"
         "  --stream-idle-timeout SECONDS  how long a stream may wait on its client, to send or to read, before\n"
         "                            it is cancelled and its slot freed (default " +
         validate::number(d.limits.stream_idle_seconds) +
         "; 0: for ever)\n"
         "  --max-sessions N          live stateful sessions (default " +
         std::to_string(d.limits.max_sessions) +
         ")\n"
         "  --max-sessions-per-client N  of those, the ones one client created (its address without the port;\n"
         "                            default: no limit of its own)\n"
         "  --max-message-bytes N     largest gRPC message either way, at most 2^31 - 1 (default " +
         std::to_string(d.limits.max_message_bytes) +
         ")\n"
         "  --max-session-bytes N     host + device bytes of all stateful sessions (default: half the device's\n"
         "                            global memory; on a CPU device at most half the cgroup memory limit)\n"
         "  --memory-budget N         bytes of sessions, stored volumes and running calls' working memory\n"
         "                            together (default: 3/4 of the cgroup memory limit, else of the RAM)\n"
         "  --max-advection-samples N  a cloud build's estimated velocity samples: active voxels x advection\n"
         "                            substeps, x2 for MacCormack (default 1e9)\n"
         "  --max-render-samples N    estimated density samples of one cloud render, an upper bound computed\n"
         "                            before it runs (default 4e11)\n"
         "  --max-bake-work N         estimated wall and polygon tests of one river bake, computed before it\n"
         "                            runs (default 1e12)\n"
         "  --grace-period SECONDS    on SIGTERM/SIGINT, time calls get to finish before they are cancelled (default "
         "10)\n"
         "  --drain-wait SECONDS      of the grace period, how long a draining squalld keeps answering UNAVAILABLE\n"
         "                            (retry elsewhere) before it closes its port, so proxies and clients see\n"
         "                            NOT_SERVING first (default 2; at most half the grace period)\n"
         "  --shutdown-bound SECONDS  past the grace period, how long cancelled calls get to stop before a\n"
         "                            watchdog ends squalld with exit code 4 (default 5)\n"
         "  --keepalive SECONDS       keepalive ping interval on idle connections, 0.1..1e6 (default 60)\n"
         "  --rpc-threads N           gRPC threads kept waiting for the next call, 1..1024 (default 32); past\n"
         "                            them a call starts a thread of its own, which ends with it\n"
         "  --reflection on|off|auto  gRPC server reflection (default auto: on only when listening on loopback\n"
         "                            without --auth-tokens)\n"
         "  --tls-cert PEM --tls-key PEM  serve TLS only, with this certificate chain and private key\n"
         "  --tls-client-ca PEM       mutual TLS: require client certificates signed by this CA\n"
         "  --tls-refresh SECONDS     re-read the TLS files this often: renewed certificates need no restart\n"
         "                            (whole seconds, 1 to 86400; default 60)\n"
         "  --auth-tokens FILE        require \"authorization: Bearer <token>\" with a token of FILE (one per line,\n"
         "                            optionally followed by a name; # comments); health stays open unless\n"
         "                            --auth-exempt-health off; SIGHUP re-reads FILE\n"
         "  --auth-exempt-health on|off  off: health checks need the token too (default on: balancers probe it)\n"
         "  --insecure on|off         allow a non-loopback --listen without TLS or tokens (default off: refused)\n"
         "  --session-ttl SECONDS     evict stateful sessions (eWave sessions, stored cloud volumes) idle this long\n"
         "                            (default 600)\n"
         "  --replica-id NAME         this replica's name, sent back on every call as x-squall-replica and logged\n"
         "                            (default hostname:port); with --state-dir, one live process per name\n"
         "  --state-dir DIR           a directory shared by the replicas: live sessions are checkpointed there\n"
         "                            (periodically and on SIGTERM), and an unknown session id is resumed from it\n"
         "  --checkpoint-interval SECONDS  how often live sessions are written to --state-dir; what a replica\n"
         "                            killed without SIGTERM loses (default 30; 0: only when draining)\n"
         "  --log-level LEVEL         debug | info | warn | error (default info)\n"
         "  --profile-kernels on|off  time every kernel launch (each waits for its kernel) and log the\n"
         "                            per-kernel table at shutdown (default off)\n";
}

}  // namespace squall::rpc
