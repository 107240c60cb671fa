#include "runtime/device.h"

#include <algorithm>
#include <cctype>
#include <sstream>

#include "common/error.h"

namespace squall {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string type_name(cl_device_type type) {
  if (type & CL_DEVICE_TYPE_GPU) return "gpu";
  if (type & CL_DEVICE_TYPE_CPU) return "cpu";
  if (type & CL_DEVICE_TYPE_ACCELERATOR) return "accelerator";
  return "other";
}

DeviceInfo read_info(const cl::Platform& platform, const cl::Device& device) {
  DeviceInfo info;
  info.platform = platform.getInfo<CL_PLATFORM_NAME>();
  info.name = device.getInfo<CL_DEVICE_NAME>();
  info.type = type_name(device.getInfo<CL_DEVICE_TYPE>());
  info.version = device.getInfo<CL_DEVICE_VERSION>();
  info.opencl_c_version = device.getInfo<CL_DEVICE_OPENCL_C_VERSION>();
  info.compute_units = device.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
  info.global_memory_bytes = device.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
  info.max_allocation_bytes = device.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
  info.double_precision = device.getInfo<CL_DEVICE_DOUBLE_FP_CONFIG>() != 0;
  return info;
}

}  // namespace

std::vector<FoundDevice> find_devices() {
  std::vector<FoundDevice> found;
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error&) {
    return found;  // CL_PLATFORM_NOT_FOUND_KHR: no ICD installed
  }
  for (const auto& platform : platforms) {
    std::vector<cl::Device> devices;
    try {
      platform.getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue;  // a platform without devices
    }
    for (const auto& device : devices) found.push_back({platform, device, read_info(platform, device)});
  }
  return found;
}

FoundDevice select_device(const std::string& spec) {
  auto devices = find_devices();
  auto first_of = [&](const std::string& type) {
    return std::find_if(devices.begin(), devices.end(), [&](const FoundDevice& d) { return d.info.type == type; });
  };
  auto pick = devices.end();
  if (spec == "auto") {
    pick = first_of("gpu");
    if (pick == devices.end()) pick = first_of("cpu");
    if (pick == devices.end()) pick = devices.begin();
  } else if (spec == "cpu" || spec == "gpu") {
    pick = first_of(spec);
  } else {
    pick = std::find_if(devices.begin(), devices.end(), [&](const FoundDevice& d) {
      return lower(d.info.platform + " " + d.info.name).find(lower(spec)) != std::string::npos;
    });
  }
  if (pick != devices.end()) return *pick;

  std::ostringstream msg;
  msg << "--device " << spec << " matches no OpenCL device; found " << devices.size() << ":";
  for (const auto& d : devices) msg << " [" << d.info.platform << " / " << d.info.name << " (" << d.info.type << ")]";
  if (devices.empty()) msg << " (is an OpenCL ICD such as pocl-opencl-icd installed?)";
  fail(Code::InvalidArgument, msg.str());
}

std::string describe(const DeviceInfo& info) {
  std::ostringstream os;
  os << "platform \"" << info.platform << "\", device \"" << info.name << "\" (" << info.type << "), "
     << info.opencl_c_version << ", " << info.compute_units << " compute units, " << (info.global_memory_bytes >> 20)
     << " MiB global memory, fp64 " << (info.double_precision ? "yes" : "no");
  return os.str();
}

}  // namespace squall
