#include "client/cli.h"

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <sstream>

#include "client/cli_flags.h"
#include "client/cloud_cli.h"
#include "client/ewave_cli.h"
#include "client/ocean_cli.h"
#include "client/texture_cli.h"
#include "common/error.h"
#include "common/regular_file.h"

namespace squall::cli {
namespace {

// info takes nothing after it, health a service name: anything else is refused, naming it (squall's own flags
// go before the verb).
int refuse_arguments(const char* verb, const std::vector<std::string>& args, size_t allowed) {
  for (size_t i = 0; i < args.size(); ++i) {
    if (global_flag(args[i]))
      return std::cerr << "squall " << verb << ": " << global_flag_after(args[i], verb) << "\n", kUsage;
    if (i >= allowed || args[i].rfind("-", 0) == 0)
      return std::cerr << "squall " << verb << ": unexpected " << args[i] << "\n", kUsage;
  }
  return kOk;
}

int info(client::Client& client, const std::vector<std::string>& args) {
  if (int status = refuse_arguments("info", args, 0); status != kOk) return status;
  auto r = client.info();
  std::cout << "squalld " << r.version() << (r.ready() ? " (ready)" : " (building kernels)") << ", up "
            << r.uptime_seconds() << " s\n";
  for (const auto& d : r.devices())
    std::cout << (d.selected() ? "* " : "  ") << d.platform() << " / " << d.name() << " (" << d.type() << ", "
              << d.opencl_c_version() << ", " << d.compute_units() << " CUs, " << (d.global_memory_bytes() >> 20)
              << " MiB)\n";
  std::cout << "replica: " << r.replica_id() << "\n";
  std::cout << "fft: " << r.fft_backend() << " (" << r.fft_selection() << ")\n";
  std::cout << "device queues: " << r.device_queues() << "\n";
  for (const auto& k : r.kernels()) {
    std::cout << "program " << k.program() << " built in " << k.build_seconds() << " s:";
    for (const auto& name : k.kernels()) std::cout << " " << name;
    std::cout << "\n";
  }
  const auto& l = r.limits();
  std::cout << "limits: max_grid_cells=" << l.max_grid_cells() << " max_streams=" << l.max_streams()
            << " max_sessions=" << l.max_sessions() << " max_message_bytes=" << l.max_message_bytes()
            << " stream_idle_timeout_seconds=" << l.stream_idle_timeout_seconds() << "\n";
  return kOk;
}

int health(client::Client& client, const std::vector<std::string>& args) {
  if (int refused = refuse_arguments("health", args, 1); refused != kOk) return refused;
  auto status = client.health(args.empty() ? "" : args[0]);
  std::cout << grpc::health::v1::HealthCheckResponse::ServingStatus_Name(status) << "\n";
  return status == grpc::health::v1::HealthCheckResponse::SERVING ? kOk : kNotServing;
}

void print_usage() {
  std::cerr << "usage: squall [--address HOST:PORT] [--timeout SECONDS] [--request-id ID] [--tls-ca PEM]\n"
               "              [--tls-cert PEM --tls-key PEM] [--token-file FILE] VERB [ARGS]\n"
               "  --address     squalld's address (default 127.0.0.1:50051)\n"
               "  --timeout     deadline of each call in seconds (default 30; a stream: per frame or step)\n"
               "  --request-id  sent as x-request-id, shown in squalld's log\n"
               "  --tls-ca      connect with TLS, trusting this CA (PEM; squalld's --tls-cert must be signed by it)\n"
               "  --tls-cert, --tls-key  this client's certificate and key for mutual TLS (PEM)\n"
               "  --token-file  send the token in this file (its first word) as a bearer token; also $SQUALL_TOKEN\n"
               "verbs:\n";
  for (const auto& [name, verb] : verbs()) std::cerr << "  " << verb.usage << "\n";
  std::cerr << "exit codes: 0 ok, 1 not serving, 2 usage, 3 unreachable, 4 refused by the server, 5 local error\n";
}

// A metadata value as gRPC sends it: printable ASCII (RFC 7230 field content; gRPC aborts the process on
// anything else). Empty when it is one, else why not.
std::string header_problem(const std::string& value) {
  for (unsigned char c : value)
    if (c < 0x20 || c > 0x7e) {
      char code[8];
      std::snprintf(code, sizeof code, "\\x%02x", c);
      return std::string("holds the byte ") + code + ": a metadata value is printable ASCII";
    }
  return "";
}

// A HOST:PORT target's port must be in 1..65535: gRPC dials it modulo 65536. Targets with a scheme gRPC resolves
// (dns:, unix:, ipv4:, ...) and bare IPv6 addresses go as given.
bool bad_port(const std::string& address) {
  static const char* const kSchemes[] = {"dns:", "unix:", "unix-abstract:", "ipv4:", "ipv6:", "vsock:", "xds:"};
  if (address.empty()) return false;
  for (const char* scheme : kSchemes)
    if (address.rfind(scheme, 0) == 0) return false;
  size_t colon;
  if (address.front() == '[') {  // [IPv6]:PORT
    const size_t close = address.find(']');
    if (close == std::string::npos || close + 1 == address.size()) return false;
    colon = close + 1;
  } else {
    colon = address.find(':');
    if (colon == std::string::npos || address.find(':', colon + 1) != std::string::npos) return false;
  }
  if (address[colon] != ':') return false;
  const std::string port = address.substr(colon + 1);
  char* end = nullptr;
  const long n = std::strtol(port.c_str(), &end, 10);
  return port.empty() || *end || !std::isdigit(static_cast<unsigned char>(port[0])) || n < 1 || n > 65535;
}

// The options' request id and token, sent as metadata: kUsage, with the message, when one cannot be.
int check_metadata(const client::ClientOptions& options) {
  for (const auto& [what, value] : {std::pair<const char*, std::string>{"--request-id", options.request_id},
                                    {"the token (--token-file or $SQUALL_TOKEN)", options.token}})
    if (std::string problem = header_problem(value); !problem.empty())
      return std::cerr << "squall: " << what << " " << problem << "\n", kUsage;
  return kOk;
}

}  // namespace

std::map<std::string, Verb>& verbs() {
  static std::map<std::string, Verb> table = {
      {"info", {"info              print the daemon's version, devices, kernels, FFT backend and limits", info}},
      {"health",
       {"health [SERVICE]  SERVING / NOT_SERVING of the server, a service, admission or liveness; exit 1 if not",
        health}},
      {"ocean", {ocean::kVerbUsage, ocean::run}},
      {"ewave", {ewave::kVerbUsage, ewave::run}},
      {"cloud", {cloud::kVerbUsage, cloud::run}},
      {"texture", {texture::kVerbUsage, texture::run}},
  };
  return table;
}

int main(int argc, char** argv) {
  client::ClientOptions options;
  if (const char* token = std::getenv("SQUALL_TOKEN")) options.token = token;
  int i = 1;
  for (; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg.rfind("--", 0) != 0) break;
    if (arg == "--help") return print_usage(), kOk;
    if (i + 1 >= argc) return std::cerr << "squall: " << arg << " needs a value\n", kUsage;
    std::string value = argv[++i];
    if (arg == "--address") {
      options.address = value;
    } else if (arg == "--timeout") {
      try {
        options.timeout_seconds = number(arg, value, "s");
      } catch (const UsageError&) {
        options.timeout_seconds = 0;
      }
      if (!(options.timeout_seconds > 0))
        return std::cerr << "squall: --timeout " << value << ": must be a number of seconds > 0\n", kUsage;
    } else if (arg == "--request-id") {
      options.request_id = value;
    } else if (arg == "--token-file") {
      std::optional<std::string> text;
      try {
        text = read_regular_file(value, "--token-file " + value);
      } catch (const Error&) {  // a FIFO, a directory, a read error: said the same way
      }
      if (!text) return std::cerr << "squall: --token-file " << value << ": cannot read\n", kUsage;
      if (!(std::istringstream(*text) >> options.token))
        return std::cerr << "squall: --token-file " << value << ": no token in it\n", kUsage;
    } else if (arg == "--tls-ca") {
      options.tls_ca = value;
    } else if (arg == "--tls-cert") {
      options.tls_cert = value;
    } else if (arg == "--tls-key") {
      options.tls_key = value;
    } else {
      return std::cerr << "squall: unknown flag " << arg << "\n", print_usage(), kUsage;
    }
  }
  if (i >= argc) return print_usage(), kUsage;
  if (int status = check_metadata(options); status != kOk) return status;
  if (options.address.empty()) return std::cerr << "squall: --address is empty\n", kUsage;
  if (bad_port(options.address))
    return std::cerr << "squall: --address " << options.address << ": the port must be in 1..65535\n", kUsage;
  auto it = verbs().find(argv[i]);
  if (it == verbs().end()) return std::cerr << "squall: unknown verb " << argv[i] << "\n", print_usage(), kUsage;
  const bool tls = !options.tls_ca.empty() || !options.tls_cert.empty() || !options.tls_key.empty();
  if (!options.token.empty() && !tls && !client::is_loopback_address(options.address))
    std::cerr << "squall: warning: the bearer token goes to " << options.address
              << " in plaintext (no --tls-ca): anyone on the path can read it\n";
  std::vector<std::string> args(argv + i + 1, argv + argc);
  try {
    client::Client client(options);
    const int status = it->second.run(client, args);
    std::cout.flush();  // what a verb prints (sample's CSV, info) is its output: a full disk is an error
    if (status == kOk && !std::cout)
      return std::cerr << "squall: the standard output could not be written\n", kLocalError;
    return status;
  } catch (const client::OptionsError& e) {  // a bad command line, as an unreadable --token-file
    std::cerr << "squall: " << e.what() << "\n";
    return kUsage;
  } catch (const client::RpcError& e) {
    std::cerr << "squall: " << e.what() << " (address " << options.address << ")\n";
    bool unreachable = e.code() == grpc::StatusCode::UNAVAILABLE || e.code() == grpc::StatusCode::DEADLINE_EXCEEDED;
    return unreachable ? kUnreachable : kRefused;
  } catch (const std::exception& e) {
    std::cerr << "squall: " << e.what() << "\n";
    return kLocalError;
  }
}

}  // namespace squall::cli
