// Mapping engine errors to gRPC statuses, in one place for every service.
#pragma once

#include <grpcpp/grpcpp.h>

#include <exception>

#include "common/error.h"
#include "runtime/opencl.h"

namespace squall::rpc {

grpc::Status to_status(const Error& error);

// An OpenCL failure: RESOURCE_EXHAUSTED where the device had too little memory for the request (a buffer past
// its largest allocation, or no memory left), INTERNAL otherwise.
grpc::Status to_status(const cl::Error& error);

// Runs one handler body and turns what it throws into the status the gRPC docs prescribe:
// squall::Error keeps its code, an OpenCL failure is to_status's, anything else INTERNAL.
// The daemon never lets an exception escape a handler.
template <typename Body>
grpc::Status guarded(Body&& body) {
  try {
    return body();
  } catch (const Error& e) {
    return to_status(e);
  } catch (const cl::Error& e) {
    return to_status(e);
  } catch (const std::bad_alloc&) {
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "host memory exhausted");
  } catch (const std::exception& e) {
    return grpc::Status(grpc::StatusCode::INTERNAL, e.what());
  }
}

}  // namespace squall::rpc
