#include "common/error.h"

namespace squall {

const char* code_name(Code code) {
  switch (code) {
    case Code::InvalidArgument: return "INVALID_ARGUMENT";
    case Code::NotFound: return "NOT_FOUND";
    case Code::AlreadyExists: return "ALREADY_EXISTS";
    case Code::ResourceExhausted: return "RESOURCE_EXHAUSTED";
    case Code::FailedPrecondition: return "FAILED_PRECONDITION";
    case Code::Aborted: return "ABORTED";
    case Code::Unavailable: return "UNAVAILABLE";
    case Code::Unauthenticated: return "UNAUTHENTICATED";
    case Code::Cancelled: return "CANCELLED";
    case Code::DataLoss: return "DATA_LOSS";
    case Code::Internal: return "INTERNAL";
  }
  return "UNKNOWN";
}

}  // namespace squall
