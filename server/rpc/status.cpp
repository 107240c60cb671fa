#include "rpc/status.h"

namespace squall::rpc {

grpc::Status to_status(const Error& error) {
  grpc::StatusCode code = grpc::StatusCode::INTERNAL;
  switch (error.code()) {
    case Code::InvalidArgument: code = grpc::StatusCode::INVALID_ARGUMENT; break;
    case Code::NotFound: code = grpc::StatusCode::NOT_FOUND; break;
    case Code::ResourceExhausted: code = grpc::StatusCode::RESOURCE_EXHAUSTED; break;
    case Code::FailedPrecondition: code = grpc::StatusCode::FAILED_PRECONDITION; break;
    case Code::Aborted: code = grpc::StatusCode::ABORTED; break;
    case Code::Unavailable: code = grpc::StatusCode::UNAVAILABLE; break;
    case Code::Unauthenticated: code = grpc::StatusCode::UNAUTHENTICATED; break;
    case Code::Cancelled: code = grpc::StatusCode::CANCELLED; break;
    case Code::Internal: code = grpc::StatusCode::INTERNAL; break;
  }
  return grpc::Status(code, error.what());
}

}  // namespace squall::rpc
