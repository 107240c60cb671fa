#include "runtime/kernel.h"

#include <cstdint>

#include "common/error.h"
#include "runtime/runtime.h"

namespace squall {
namespace {

const char* spec_text(const KernelArgSpec& spec) {
  switch (spec.kind) {
    case KernelArgSpec::Kind::GlobalPointer: return "a __global or __constant pointer (cl::Buffer)";
    case KernelArgSpec::Kind::LocalPointer: return "a __local pointer (cl::LocalSpaceArg)";
    default: return spec.type_name;
  }
}

const char* space_text(cl_kernel_arg_address_qualifier space) {
  switch (space) {
    case CL_KERNEL_ARG_ADDRESS_GLOBAL: return "__global ";
    case CL_KERNEL_ARG_ADDRESS_CONSTANT: return "__constant ";
    case CL_KERNEL_ARG_ADDRESS_LOCAL: return "__local ";
    default: return "";
  }
}

bool matches(const KernelArgSpec& spec, cl_kernel_arg_address_qualifier space, const std::string& type) {
  bool pointer = !type.empty() && type.back() == '*';
  switch (spec.kind) {
    case KernelArgSpec::Kind::GlobalPointer:
      return pointer && (space == CL_KERNEL_ARG_ADDRESS_GLOBAL || space == CL_KERNEL_ARG_ADDRESS_CONSTANT);
    case KernelArgSpec::Kind::LocalPointer: return pointer && space == CL_KERNEL_ARG_ADDRESS_LOCAL;
    case KernelArgSpec::Kind::Scalar: return type == spec.type_name;
    case KernelArgSpec::Kind::Struct: return type == spec.type_name || type == std::string("struct ") + spec.type_name;
  }
  return false;
}

// The type name the device reports (trailing NULs and blanks removed: implementations differ).
std::string type_name(const cl::Kernel& kernel, cl_uint index) {
  std::string type = kernel.getArgInfo<CL_KERNEL_ARG_TYPE_NAME>(index);
  while (!type.empty() && (type.back() == '\0' || type.back() == ' ')) type.pop_back();
  return type;
}

}  // namespace

void not_created() { fail(Code::Internal, "a Kernel<...> was launched before it was created"); }

cl::Kernel create_kernel(Runtime& runtime, const std::string& program, const std::string& name) {
  try {
    return runtime.kernel(program, name);
  } catch (const cl::Error& e) {  // e.g. CL_INVALID_KERNEL_NAME: the kernel was renamed
    fail(Code::Internal,
         "kernel " + name + " of " + program + " cannot be created (OpenCL error " + std::to_string(e.err()) + ")");
  }
}

size_t queue_count(const Runtime& runtime) { return runtime.queue_count(); }

void verify_kernel_args(const cl::Kernel& kernel, const std::string& program, const std::string& name,
                        const std::vector<KernelArgSpec>& expected) {
  const std::string where = "kernel " + name + " of " + program;
  cl_uint count = kernel.getInfo<CL_KERNEL_NUM_ARGS>();
  if (count != expected.size())
    fail(Code::Internal, where + " takes " + std::to_string(count) + " arguments; the host declares " +
                             std::to_string(expected.size()));
  for (cl_uint i = 0; i < count; ++i) {
    cl_kernel_arg_address_qualifier space;
    try {
      space = kernel.getArgInfo<CL_KERNEL_ARG_ADDRESS_QUALIFIER>(i);
    } catch (const cl::Error& e) {
      if (e.err() == CL_KERNEL_ARG_INFO_NOT_AVAILABLE) return;  // built without -cl-kernel-arg-info
      throw;
    }
    std::string type = type_name(kernel, i);
    if (!matches(expected[i], space, type))
      fail(Code::Internal, where + ": argument " + std::to_string(i) + " (" +
                               kernel.getArgInfo<CL_KERNEL_ARG_NAME>(i).c_str() + ") is " + space_text(space) + type +
                               " on the device; the host declares " + spec_text(expected[i]));
  }
}

size_t work_group_limit(Runtime& runtime, const cl::Kernel& kernel) {
  const cl::Device& device = runtime.device();
  if (kernel.getWorkGroupInfo<CL_KERNEL_LOCAL_MEM_SIZE>(device) > 0) return SIZE_MAX;
  return kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device);
}

void launch_kernel(Runtime& runtime, const cl::Kernel& kernel, const std::string& program, const std::string& name,
                   const cl::NDRange& offset, const cl::NDRange& global, const cl::NDRange& local, size_t group_limit) {
  size_t items = 1;
  for (cl_uint d = 0; d < local.dimensions(); ++d) items *= local[d];
  const cl::NDRange& group = items <= group_limit ? local : cl::NullRange;
  if (!runtime.profiling()) {
    runtime.queue().enqueueNDRangeKernel(kernel, offset, global, group);
    return;
  }
  cl::Event event;
  runtime.queue().enqueueNDRangeKernel(kernel, offset, global, group, nullptr, &event);
  event.wait();
  cl_ulong start = event.getProfilingInfo<CL_PROFILING_COMMAND_START>();
  cl_ulong end = event.getProfilingInfo<CL_PROFILING_COMMAND_END>();
  runtime.record_kernel_time(program, name, end > start ? end - start : 0);
}

}  // namespace squall
