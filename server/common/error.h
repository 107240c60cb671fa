// squall::Error: the one exception type the engines throw. Its code says which gRPC status the RPC
// layer answers with; its message names the offending field or limit, so a client can act on it.
#pragma once

#include <stdexcept>
#include <string>

namespace squall {

// A subset of gRPC's status codes, used as the gRPC documentation defines them.
enum class Code {
  InvalidArgument,     // the request itself is wrong (NaN, negative size, wrong map shape)
  NotFound,            // an id that does not exist (or belongs to someone else)
  AlreadyExists,       // an id the client proposed for a new session is taken (live or checkpointed)
  ResourceExhausted,   // a limit in force is exceeded (cells, streams, sessions, memory)
  FailedPrecondition,  // the request is valid but the daemon is not in a state to run it
  Aborted,             // a sequencer check failed (a step's expected count): retry from a fresh read
  Unavailable,         // the daemon is starting up or draining
  Unauthenticated,     // no valid credentials (--auth-tokens)
  Cancelled,           // the caller gave up (gone, deadline passed) or squalld shut down mid-work
  DataLoss,            // stored data (a session's checkpoint file) is damaged or unreadable
  Internal,            // a bug or a device failure; never the client's fault
};

const char* code_name(Code code);

class Error : public std::runtime_error {
 public:
  Error(Code code, const std::string& message) : std::runtime_error(message), code_(code) {}
  Code code() const { return code_; }

 private:
  Code code_;
};

[[noreturn]] inline void fail(Code code, const std::string& message) { throw Error(code, message); }

}  // namespace squall
