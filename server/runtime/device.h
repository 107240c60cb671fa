// OpenCL device discovery and selection.
#pragma once

#include <string>
#include <vector>

#include "runtime/opencl.h"

namespace squall {

struct DeviceInfo {
  std::string platform;
  std::string name;
  std::string type;              // "cpu", "gpu", "accelerator", "other"
  std::string version;           // CL_DEVICE_VERSION
  std::string opencl_c_version;  // CL_DEVICE_OPENCL_C_VERSION
  unsigned compute_units = 0;
  unsigned long long global_memory_bytes = 0;
  unsigned long long max_allocation_bytes = 0;
  bool double_precision = false;
};

struct FoundDevice {
  cl::Platform platform;
  cl::Device device;
  DeviceInfo info;
};

// Every device of every platform, in platform order. Empty when no ICD is installed.
std::vector<FoundDevice> find_devices();

// Picks a device by a --device spec:
//   auto  the first GPU, else the first CPU (PoCL), else the first device;
//   cpu / gpu  the first device of that type;
//   any other text  the first device whose "platform name" or "device name" contains it
//                   (case-insensitive).
// Throws Error(InvalidArgument) naming the spec and listing the devices when none matches.
FoundDevice select_device(const std::string& spec);

std::string describe(const DeviceInfo& info);  // one line for the log

}  // namespace squall
