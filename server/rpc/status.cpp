#include "rpc/status.h"

namespace squall::rpc {

grpc::Status to_status(const cl::Error& error) {
  const std::string call = std::string("OpenCL call ") + error.what() + " failed with " + std::to_string(error.err());
  switch (error.err()) {
    case CL_INVALID_BUFFER_SIZE:
      return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                          "the request needs a device buffer larger than the device's largest allocation (" + call +
                              ", CL_INVALID_BUFFER_SIZE): ask for a smaller grid");
    // Not CL_OUT_OF_RESOURCES, which NVIDIA's driver also returns for a kernel's faults: INTERNAL.
    case CL_MEM_OBJECT_ALLOCATION_FAILURE:
    case CL_OUT_OF_HOST_MEMORY:
      return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                          "the device has too little memory left for the request (" + call + ")");
    default: return grpc::Status(grpc::StatusCode::INTERNAL, call);
  }
}

grpc::Status to_status(const Error& error) {
  grpc::StatusCode code = grpc::StatusCode::INTERNAL;
  switch (error.code()) {
    case Code::InvalidArgument: code = grpc::StatusCode::INVALID_ARGUMENT; break;
    case Code::NotFound: code = grpc::StatusCode::NOT_FOUND; break;
    case Code::AlreadyExists: code = grpc::StatusCode::ALREADY_EXISTS; break;
    case Code::ResourceExhausted: code = grpc::StatusCode::RESOURCE_EXHAUSTED; break;
    case Code::FailedPrecondition: code = grpc::StatusCode::FAILED_PRECONDITION; break;
    case Code::Aborted: code = grpc::StatusCode::ABORTED; break;
    case Code::Unavailable: code = grpc::StatusCode::UNAVAILABLE; break;
    case Code::Unauthenticated: code = grpc::StatusCode::UNAUTHENTICATED; break;
    case Code::Cancelled: code = grpc::StatusCode::CANCELLED; break;
    case Code::DataLoss: code = grpc::StatusCode::DATA_LOSS; break;
    case Code::Internal: code = grpc::StatusCode::INTERNAL; break;
  }
  return grpc::Status(code, error.what());
}

}  // namespace squall::rpc
