// How the shared RPC layer reports what a handler throws: the status codes of the gRPC docs.
#include <gtest/gtest.h>

#include "rpc/status.h"
#include "support/test_runtime.h"

namespace squall::rpc {
namespace {

// A buffer past the device's largest allocation is a request too large for the device, not a fault of the
// server: RESOURCE_EXHAUSTED (an Eulerian texture grid of 4096^2 cells was INTERNAL, "clCreateBuffer failed
// with -61"). Other OpenCL failures stay INTERNAL.
TEST(Status, ADeviceBufferPastTheLargestAllocationIsResourceExhausted) {
  Runtime& runtime = squall::test::runtime();
  const size_t largest = runtime.device().getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
  const grpc::Status status = guarded([&] {
    cl::Buffer too_large(runtime.context(), CL_MEM_READ_WRITE, largest + 4096);
    return grpc::Status::OK;
  });
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("largest allocation"), std::string::npos) << status.error_message();
  EXPECT_EQ(to_status(cl::Error(CL_MEM_OBJECT_ALLOCATION_FAILURE, "clEnqueueNDRangeKernel")).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(to_status(cl::Error(CL_INVALID_KERNEL_ARGS, "clEnqueueNDRangeKernel")).error_code(),
            grpc::StatusCode::INTERNAL);
}

}  // namespace
}  // namespace squall::rpc
