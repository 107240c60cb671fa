#include "daemon/daemon.h"

#include <unistd.h>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/impl/server_builder_option.h>
#include <grpcpp/resource_quota.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/security/tls_certificate_provider.h>
#include <grpcpp/security/tls_credentials_options.h>
#include <prometheus/exposer.h>
#include <signal.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <future>
#include <iterator>
#include <sstream>
#include <thread>
#include <stdexcept>
#include <memory>
#include <optional>
#include <vector>

#include "clouds/clouds_service.h"
#include "common/log.h"
#include "common/regular_file.h"
#include "common/state_dir.h"
#include "common/watchdog.h"
#include "daemon/admission_watch.h"
#include "daemon/beat.h"
#include "daemon/checkpoint_loop.h"
#include "daemon/daemon_metrics.h"
#include "daemon/daemon_state.h"
#include "daemon/health_service.h"
#include "daemon/server_service.h"
#include "ewave/ewave_service.h"
#include "ocean/ocean_service.h"
#include "rpc/reflection_limit.h"
#include "rpc/request_log.h"
#include "rpc/undecodable_request.h"
#include "runtime/cpu_threads.h"
#include "textures/textures_service.h"

namespace squall::rpc {
namespace {

// SIGTERM and SIGINT drain and stop squalld; SIGHUP re-reads the --auth-tokens file.
sigset_t handled_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGHUP);
  return set;
}

// Every capability squalld serves. Adding one is one line here.
std::vector<std::unique_ptr<Capability>> capabilities(ServingState& serving) {
  std::vector<std::unique_ptr<Capability>> all;
  all.push_back(std::make_unique<OceanService>(serving));
  all.push_back(std::make_unique<EWaveService>(serving));
  all.push_back(std::make_unique<CloudsService>(serving));
  all.push_back(std::make_unique<TexturesService>(serving));
  return all;
}

// Compiles every kernel program, chooses the FFT backend and starts every capability: the work that
// precedes SERVING. FFTW's wisdom is kept in --fft-wisdom, by default the kernel cache, beside the
// kernels PoCL compiled.
void start_engines(DaemonState& daemon, const DaemonOptions& options, const std::string& cache,
                   const std::vector<std::unique_ptr<Capability>>& capabilities) {
  daemon.runtime.build_programs();
  fft::FftwOptions fftw = options.fftw;
  fftw.wisdom_dir = options.fft_wisdom.empty() ? cache : options.fft_wisdom == "none" ? "" : options.fft_wisdom;
  const std::string backend = fft::chosen_backend(daemon.runtime, options.fft, &daemon.fft_selection, fftw);
  daemon.fft = std::make_unique<fft::Fft>(fft::make_backend(daemon.runtime, backend, fftw));
  log(LogLevel::Info, "FFT backend ", backend, " (", daemon.fft_selection, ")");
  SessionPolicy sessions;
  sessions.ttl = std::chrono::milliseconds(std::llround(options.session_ttl_seconds * 1000));
  sessions.registry = &daemon.sessions;
  daemon.engines = std::make_unique<EngineContext>(daemon.runtime, *daemon.fft, daemon.serving.gate(), sessions);
  for (const auto& capability : capabilities) capability->start(*daemon.engines);
}

void configure(grpc::ServerBuilder& builder, const DaemonOptions& options, const std::string& replica,
               Metrics* metrics) {
  int max_bytes = static_cast<int>(std::min<uint64_t>(options.limits.max_message_bytes, INT32_MAX));
  builder.SetMaxReceiveMessageSize(max_bytes);
  builder.SetMaxSendMessageSize(max_bytes);
  int keepalive_ms = static_cast<int>(options.keepalive_seconds * 1000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, keepalive_ms);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 20000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  // Clients may ping as often as every 10 s without being sent GOAWAY.
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10000);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  // A second squalld on a port in use must fail, not silently share the port with the first.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  // gRPC's synchronous server keeps at most MAX_POLLERS idle threads (default 2) and starts a thread for a
  // call that finds none: under a few clients' load that was hundreds of threads started and ended a
  // second. Up to --rpc-threads now wait for the next call.
  builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::MAX_POLLERS, options.rpc_threads);
  // Every running call holds a thread: at most --max-calls unary ones, --max-streams streams, the health
  // service's Watch streams and the reflection streams, with the idle pollers and 64 more for health checks
  // and refusing calls past the limits by name. Past this many threads gRPC itself answers
  // RESOURCE_EXHAUSTED ("Server Threadpool Exhausted"), from the last idle poller.
  const int64_t threads = int64_t(options.limits.max_calls) + options.limits.max_streams + options.rpc_threads +
                          HealthService::kMaxWatches + ReflectionLimitFactory::kMaxStreams + 64;
  grpc::ResourceQuota quota("squalld");
  quota.SetMaxThreads(int(std::min<int64_t>(threads, INT32_MAX)));
  builder.SetResourceQuota(quota);
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<UndecodableRequestFactory>());  // first: the log shows the status it sets
  interceptors.push_back(std::make_unique<ReflectionLimitFactory>());     // before the log: it reads its status
  interceptors.push_back(std::make_unique<RequestLogFactory>(replica, metrics));
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
}

// Removes gRPC's reflection plugin from a builder: libgrpc++_reflection adds it to every builder as soon
// as the library is loaded, so --reflection off has to take it out again.
class WithoutReflection : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    std::erase_if(*plugins, [](const auto& p) {
      return dynamic_cast<grpc::reflection::ProtoServerReflectionPlugin*>(p.get()) != nullptr;
    });
  }
};

// Fails with a message naming the flag unless `path` is a readable PEM file.
void check_pem(const std::string& path, const char* flag) {
  const std::optional<std::string> text = read_regular_file(path, std::string(flag) + " " + path);
  if (!text) throw std::runtime_error(std::string(flag) + " " + path + ": cannot read the file");
  if (text->find("-----BEGIN ") == std::string::npos)
    throw std::runtime_error(std::string(flag) + " " + path + ": not a PEM file");
}

// The tokens of --auth-tokens: the first word of each line, a name may follow; blank lines and lines
// starting with '#' are skipped, and so is a UTF-8 byte order mark at its start. No file: no tokens (no
// authentication); a file without any: an error.
std::vector<std::string> read_tokens(const std::string& path) {
  if (path.empty()) return {};
  std::optional<std::string> text = read_regular_file(path, "--auth-tokens " + path);
  if (!text) throw std::runtime_error("--auth-tokens " + path + ": cannot read the file");
  if (text->starts_with("\xEF\xBB\xBF")) text->erase(0, 3);
  std::istringstream in(*text);
  std::vector<std::string> tokens;
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    std::string token;
    if (words >> token && token[0] != '#') tokens.push_back(token);
  }
  if (tokens.empty()) throw std::runtime_error("--auth-tokens " + path + ": no tokens in the file");
  log(LogLevel::Info, "authentication: ", tokens.size(), " bearer tokens from ", path);
  return tokens;
}

// Plaintext, or TLS with --tls-cert / --tls-key, and client certificates verified against --tls-client-ca.
// The files are checked here (a clear error at start) and then watched: gRPC's file watcher re-reads
// them every --tls-refresh seconds, so a renewed certificate is served to new connections without a
// restart and live streams keep theirs.
std::shared_ptr<grpc::ServerCredentials> server_credentials(const DaemonOptions& options) {
  if (options.tls_cert.empty()) return grpc::InsecureServerCredentials();
  check_pem(options.tls_key, "--tls-key");
  check_pem(options.tls_cert, "--tls-cert");
  if (!options.tls_client_ca.empty()) check_pem(options.tls_client_ca, "--tls-client-ca");
  auto files = std::make_shared<grpc::experimental::FileWatcherCertificateProvider>(
      options.tls_key, options.tls_cert, options.tls_client_ca, options.tls_refresh_seconds);
  grpc::experimental::TlsServerCredentialsOptions tls(files);
  tls.watch_identity_key_cert_pairs();
  if (!options.tls_client_ca.empty()) {
    tls.watch_root_certs();
    tls.set_cert_request_type(GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  }
  return grpc::experimental::TlsServerCredentials(tls);
}

// PoCL writes every compiled kernel to its cache: with an unwritable one (a read-only root file system)
// the first kernel build fails with a misleading error, so the directory is checked first, by name.
void require_writable_kernel_cache(const std::string& dir) {
  if (std::string why = unwritable_directory(dir); !why.empty())
    throw std::runtime_error("kernel cache " + dir + ": " + why +
                             "; PoCL stores compiled kernels there: give --cache-dir (or POCL_CACHE_DIR) a writable "
                             "directory, e.g. on a tmpfs when the root file system is read-only");
}

std::unique_ptr<StateDir> state_dir(const DaemonOptions& options) {
  if (options.state_dir.empty()) return nullptr;
  auto dir = std::make_unique<StateDir>(options.state_dir, "--state-dir");
  log(LogLevel::Info, "state directory ", options.state_dir, ": sessions checkpointed every ",
      options.checkpoint_interval_seconds, " s (--checkpoint-interval) and on SIGTERM");
  return dir;
}

std::chrono::milliseconds milliseconds(double seconds) {
  return std::chrono::milliseconds(std::llround(seconds * 1000));
}

// Every capability's sessions idle past --session-ttl, now (the daemon's sweeper calls it every second).
void evict_idle_sessions(const std::vector<std::unique_ptr<Capability>>& capabilities) {
  for (const auto& capability : capabilities) {
    try {
      capability->evict_idle();
    } catch (const std::exception& e) {
      log(LogLevel::Error, "evicting idle sessions: ", e.what());
    }
  }
}

// Drains: health NOT_SERVING, no new sessions or stateless calls, every live session written to the state
// directory and released (its later calls answer UNAVAILABLE, and another replica resumes it); calls
// keep being answered (UNAVAILABLE: retry elsewhere) for --drain-wait, while proxies and clients notice
// NOT_SERVING, since a call that reaches a closing server is CANCELLED before any handler sees it, which no
// retry policy retries (it carries no x-squall-replica: the Python client sends it again); then the calls
// still in flight get the rest of the grace period.
void drain(DaemonState& daemon, grpc::Server& server, HealthService& health, CheckpointLoop& checkpoints,
           const DaemonOptions& options) {
  const auto deadline = std::chrono::system_clock::now() + milliseconds(options.grace_seconds);
  // Calls are cancelled at the end of the grace period and long work stops within a slice; one that does
  // not (a single long device launch) is ended with the process.
  std::ostringstream overran;
  overran << "a call still runs " << options.shutdown_bound_seconds
          << " s (--shutdown-bound) after the grace period ended: exiting without it";
  Watchdog watchdog(milliseconds(options.grace_seconds + options.shutdown_bound_seconds), kExitOverran, overran.str());
  health.SetServingStatus(false);
  daemon.serving.set_phase(ServingState::Phase::Draining);
  daemon.sessions.begin_drain();
  checkpoints.stop_work();
  if (daemon.sessions.state_dir())
    log(LogLevel::Info, "checkpointed ", daemon.sessions.checkpoint_all(true), " sessions to ",
        daemon.sessions.state_dir()->path());
  std::this_thread::sleep_for(milliseconds(std::min(options.drain_wait_seconds, options.grace_seconds / 2)));
  health.Shutdown();  // watches end: the server closes
  server.Shutdown(deadline);
  server.Wait();
  checkpoints.stop();
  if (daemon.sessions.state_dir()) daemon.sessions.state_dir()->retire(daemon.sessions.replica());
}

// Prometheus's text format at http://--metrics-listen/metrics: the calls' metrics and the daemon's
// gauges. The exposer holds its collectables by weak pointer: the endpoint owns the daemon's (and is
// destroyed after the exposer stops). A connection holds one of its threads until its request is read or the
// read times out, so a few idle connections (a port scan, a client that connects early) must not starve a
// scrape: several threads, and a read timeout well under Prometheus's 10 s scrape timeout.
struct MetricsEndpoint {
  MetricsEndpoint(const std::string& address, const Metrics& metrics, const DaemonState& daemon,
                  const std::vector<std::unique_ptr<Capability>>& capabilities)
      : gauges(std::make_shared<DaemonMetrics>(daemon, capabilities)),
        exposer(
            std::vector<std::string>{"listening_ports", address, "num_threads", "4", "request_timeout_ms", "3000"}) {
    exposer.RegisterCollectable(metrics.registry());
    exposer.RegisterCollectable(gauges);
    const auto ports = exposer.GetListeningPorts();
    log(LogLevel::Info, "metrics at http://", address, "/metrics (port ", ports.empty() ? 0 : ports.front(), ")");
  }
  std::shared_ptr<DaemonMetrics> gauges;
  prometheus::Exposer exposer;
};

// SIGHUP: re-reads --auth-tokens, keeping the tokens in force when the file cannot be read or holds none.
// TLS files need no signal: they are watched.
void reload_tokens(ServingState& serving, const DaemonOptions& options) {
  if (options.auth_tokens.empty()) {
    log(LogLevel::Info, "received SIGHUP; nothing to reload (no --auth-tokens)");
    return;
  }
  try {
    serving.set_tokens(read_tokens(options.auth_tokens));
  } catch (const std::exception& e) {
    log(LogLevel::Error, "SIGHUP: ", e.what(), "; the tokens in force stay");
  }
}

// Waits for SIGTERM or SIGINT (returned), reloading the tokens on each SIGHUP.
int wait_for_shutdown(const sigset_t& signals, ServingState& serving, const DaemonOptions& options) {
  for (;;) {
    int signal_number = 0;
    sigwait(&signals, &signal_number);
    if (signal_number != SIGHUP) return signal_number;
    reload_tokens(serving, options);
  }
}

// start_engines() on a thread of its own while this one waits for signals: SIGTERM or SIGINT during the
// kernel build (minutes with a cold cache) ends the process at once, with nothing to drain yet (no session
// exists, and every call but GetInfo and health was answered UNAVAILABLE). Rethrows start_engines()'s
// exception; returns once it has returned.
void start_engines_or_stop(DaemonState& daemon, const DaemonOptions& options, const std::string& cache,
                           const std::vector<std::unique_ptr<Capability>>& capabilities, const sigset_t& signals) {
  std::future<void> started =
      std::async(std::launch::async, [&] { start_engines(daemon, options, cache, capabilities); });
  const timespec poll{0, 100'000'000};  // 0.1 s
  while (started.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
    const int signal_number = sigtimedwait(&signals, nullptr, &poll);
    if (signal_number == SIGHUP) reload_tokens(daemon.serving, options);
    if (signal_number != SIGTERM && signal_number != SIGINT) continue;
    log(LogLevel::Info, "received ", strsignal(signal_number), " while starting: exiting");
    std::_Exit(kExitOk);
  }
  started.get();
}

void write_port_file(const std::string& path, int port) {
  if (path.empty()) return;
  std::string tmp = path + ".tmp";
  std::ofstream(tmp) << port << "\n";
  std::rename(tmp.c_str(), path.c_str());  // readers never see a half-written file
}

}  // namespace

uint64_t usable_memory() {
  if (const uint64_t cgroup = cgroup_memory_limit()) return cgroup;
  return uint64_t(sysconf(_SC_PHYS_PAGES)) * uint64_t(sysconf(_SC_PAGE_SIZE));
}

int run_daemon(const DaemonOptions& options) {
  set_log_level(options.log_level);
  // Block the handled signals in every thread (gRPC's included, created later); main waits for them.
  sigset_t signals = handled_signals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  const std::string replica = replica_id(options);
  fit_cpu_threads_to_quota();  // before gRPC's threads and the ICD loader start
  const std::string cache = configure_kernel_cache(options.cache_dir);
  log(LogLevel::Info, "squalld ", SQUALL_VERSION, " starting as replica ", replica, "; kernel cache ", cache);
  std::unique_ptr<DaemonState> daemon;
  std::shared_ptr<grpc::ServerCredentials> credentials;
  try {
    require_writable_kernel_cache(cache);
    credentials = server_credentials(options);
    std::vector<std::string> tokens = read_tokens(options.auth_tokens);
    daemon = std::make_unique<DaemonState>(options.runtime, options.limits, state_dir(options), replica);
    daemon->sessions.begin();
    daemon->serving.set_tokens(std::move(tokens));
    daemon->serving.set_replica_id(replica);
  } catch (const std::exception& e) {
    log(LogLevel::Error, e.what());
    return kExitUsage;
  }

  const Limits& limits = daemon->serving.gate().limits();
  log(LogLevel::Info, "limits: ", limits.max_sessions, " sessions holding at most ", limits.max_session_bytes,
      " bytes (--max-sessions, --max-session-bytes), ", limits.max_streams, " streams, ", limits.max_grid_cells,
      " cells per field, ", limits.memory_budget, " bytes of memory in all (--memory-budget)");
  ServerService server_service(*daemon);
  // The heartbeat from begin() on, through the kernel build: a second process under this --replica-id
  // meanwhile finds it beating and refuses to start.
  CheckpointLoop checkpoints(daemon->sessions, milliseconds(options.checkpoint_interval_seconds),
                             milliseconds(options.session_ttl_seconds));
  const auto served = capabilities(daemon->serving);
  grpc::EnableDefaultHealthCheckService(false);  // squall's own: it can ask for a token
  HealthService health(daemon->serving, options.auth_exempt_health);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  if (!reflection_enabled(options)) builder.SetOption(std::make_unique<WithoutReflection>());
  int port = 0;
  builder.AddListeningPort(options.listen, credentials, &port);
  builder.RegisterService(&server_service);
  builder.RegisterService(&health);
  for (const auto& capability : served) builder.RegisterService(&capability->service());
  Metrics metrics;
  configure(builder, options, replica, &metrics);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || port == 0) {
    log(LogLevel::Error, "cannot listen on ", options.listen);
    return kExitListen;
  }
  std::unique_ptr<MetricsEndpoint> metrics_endpoint;
  try {
    if (!options.metrics_listen.empty())
      metrics_endpoint = std::make_unique<MetricsEndpoint>(options.metrics_listen, metrics, *daemon, served);
  } catch (const std::exception& e) {
    log(LogLevel::Error, "--metrics-listen ", options.metrics_listen, ": ", e.what());
    health.Shutdown();  // a watch would keep the server from closing
    server->Shutdown();
    return kExitListen;
  }
  for (const auto& capability : served) health.SetServingStatus(capability->service_name(), false);
  health.SetServingStatus(squall::v1::Server::service_full_name(), false);
  health.SetServingStatus(HealthService::kAdmission, false);
  health.SetServingStatus(HealthService::kLiveness, true);  // up: signals are answered from now on
  write_port_file(options.port_file, port);
  const char* transport = options.tls_cert.empty() ? "plaintext" : options.tls_client_ca.empty() ? "TLS" : "mutual TLS";
  log(LogLevel::Info, "listening on ", options.listen, " (port ", port, ", ", transport,
      "); NOT_SERVING until kernels are built");

  try {
    start_engines_or_stop(*daemon, options, cache, served, signals);
  } catch (const std::exception& e) {
    log(LogLevel::Error, e.what());
    health.Shutdown();
    server->Shutdown();
    return kExitKernelBuild;
  }
  daemon->serving.set_phase(ServingState::Phase::Serving);
  health.SetServingStatus(true);
  log(LogLevel::Info, "SERVING");
  AdmissionWatch admission(daemon->serving.gate(), daemon->sessions, health);
  Beat sweeper(std::chrono::seconds(1), [&served] { evict_idle_sessions(served); });

  int signal_number = wait_for_shutdown(signals, daemon->serving, options);
  log(LogLevel::Info, "received ", strsignal(signal_number), "; draining for up to ", options.grace_seconds, " s");
  admission.stop();
  sweeper.stop();
  drain(*daemon, *server, health, checkpoints, options);
  if (options.runtime.profile_kernels)
    log(LogLevel::Info, "device time per kernel:\n", format_kernel_timings(daemon->runtime.kernel_timings()));
  const size_t unsaved = daemon->sessions.unsaved();
  if (unsaved > 0)
    log(LogLevel::Error, unsaved,
        " sessions could not be checkpointed: they resume elsewhere from their last "
        "checkpoint, and what they did since is lost (exit code 5)");
  log(LogLevel::Info, "stopped");
  return unsaved > 0 ? kExitUnsaved : kExitOk;
}

}  // namespace squall::rpc
