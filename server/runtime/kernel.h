// squall::Kernel<Args...>: a kernel whose argument list is declared once on the host, next to its name,
// and checked twice: at compile time, a launch whose arguments' decayed types are not exactly Args does
// not compile (an int where the kernel takes a uint is caught); at creation, the device's own view of the
// kernel (CL_KERNEL_NUM_ARGS, and with -cl-kernel-arg-info each argument's type name and address space)
// must match, or Error(Internal) names the program, the kernel and the argument. One launch entry point
// enqueues on the calling thread's queue and, in profile mode, records the kernel's device time. In the
// spirit of cl::KernelFunctor (Khronos OpenCL C++ bindings) and of pbrt-v4's single GPU launch entry
// point, GPUParallelFor (Pharr, Jakob, Humphreys, "Physically Based Rendering", 4th ed., chapter 15).
//
//   Kernel<cl::Buffer, cl_int, cl_float> scale(runtime, "x/x.cl", "scale");
//   scale.launch(cl::NDRange(n), cl::NullRange, buffer, cl_int(n), 2.0f);
//
// Struct arguments passed by value need a name on the device side: SQUALL_KERNEL_STRUCT(CloudRenderParams)
// (at global scope, once per struct) declares it.
#pragma once

#include <cstddef>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

#include "runtime/opencl.h"
#include "runtime/queue_slots.h"

namespace squall {

class Runtime;

// What the host expects of one kernel argument.
struct KernelArgSpec {
  enum class Kind { Scalar, Struct, GlobalPointer, LocalPointer };
  Kind kind;
  const char* type_name;  // the OpenCL C type name (Scalar, Struct); null for pointers
};

// The OpenCL C view of each host argument type. Not defined for other types, so an unknown type does not
// compile. cl_float3 is cl_float4 on the host (cl_platform.h): a kernel taking float3 reads as float4.
template <typename T>
struct KernelArgTraits;

#define SQUALL_KERNEL_SCALAR(HostType, ClName)                                \
  template <>                                                                 \
  struct KernelArgTraits<HostType> {                                          \
    static constexpr KernelArgSpec spec{KernelArgSpec::Kind::Scalar, ClName}; \
  };
SQUALL_KERNEL_SCALAR(cl_char, "char")
SQUALL_KERNEL_SCALAR(cl_uchar, "uchar")
SQUALL_KERNEL_SCALAR(cl_short, "short")
SQUALL_KERNEL_SCALAR(cl_ushort, "ushort")
SQUALL_KERNEL_SCALAR(cl_int, "int")
SQUALL_KERNEL_SCALAR(cl_uint, "uint")
SQUALL_KERNEL_SCALAR(cl_long, "long")
SQUALL_KERNEL_SCALAR(cl_ulong, "ulong")
SQUALL_KERNEL_SCALAR(cl_float, "float")
SQUALL_KERNEL_SCALAR(cl_double, "double")
SQUALL_KERNEL_SCALAR(cl_int2, "int2")
SQUALL_KERNEL_SCALAR(cl_int4, "int4")
SQUALL_KERNEL_SCALAR(cl_uint2, "uint2")
SQUALL_KERNEL_SCALAR(cl_uint4, "uint4")
SQUALL_KERNEL_SCALAR(cl_float2, "float2")
SQUALL_KERNEL_SCALAR(cl_float4, "float4")
SQUALL_KERNEL_SCALAR(cl_double2, "double2")
SQUALL_KERNEL_SCALAR(cl_double4, "double4")
#undef SQUALL_KERNEL_SCALAR

template <>
struct KernelArgTraits<cl::Buffer> {  // a __global or __constant pointer
  static constexpr KernelArgSpec spec{KernelArgSpec::Kind::GlobalPointer, nullptr};
};
template <>
struct KernelArgTraits<cl::LocalSpaceArg> {  // a __local pointer
  static constexpr KernelArgSpec spec{KernelArgSpec::Kind::LocalPointer, nullptr};
};

// Throws Error(Internal) naming program, kernel and argument when the device's kernel does not take
// `expected` (count always; types and address spaces when the program has kernel argument info).
void verify_kernel_args(const cl::Kernel& kernel, const std::string& program, const std::string& name,
                        const std::vector<KernelArgSpec>& expected);

// Enqueues an NDRange of `kernel` (arguments set) on the runtime's queue, its ids starting at `offset`
// (cl::NullRange: 0), in groups of `local`, or of the device's choice where `local` has more items than
// `group_limit` (work_group_limit()); in profile mode waits for it and adds its device time under
// (program, name).
void launch_kernel(Runtime& runtime, const cl::Kernel& kernel, const std::string& program, const std::string& name,
                   const cl::NDRange& offset, const cl::NDRange& global, const cl::NDRange& local, size_t group_limit);

// The most work-items a launch of `kernel` may group as it asks: the device's limit for this kernel
// (rows of kRowGroup may be more than a GPU runs a register-heavy kernel in), or no limit when the kernel
// uses __local memory (its groups are then part of what it computes, not only a layout).
size_t work_group_limit(Runtime& runtime, const cl::Kernel& kernel);

[[noreturn]] void not_created();  // Error(Internal): a default-constructed Kernel was launched

// runtime.kernel(program, name), out of line so that this header needs only a declaration of Runtime;
// Error(Internal) when the program has no such kernel.
cl::Kernel create_kernel(Runtime& runtime, const std::string& program, const std::string& name);
size_t queue_count(const Runtime& runtime);  // runtime.queue_count(), out of line as well

// True when Given... (decayed) is exactly Expected..., element by element.
template <typename Given, typename Expected>
struct KernelArgsMatch : std::false_type {};
template <typename... Given, typename... Expected>
requires(sizeof...(Given) == sizeof...(Expected)) struct KernelArgsMatch<std::tuple<Given...>, std::tuple<Expected...>>
    : std::bool_constant<(std::is_same_v<std::decay_t<Given>, Expected> && ...)> {
};

// Rounds n up to a multiple of m (global work sizes).
inline size_t round_up(size_t n, size_t m) { return (n + m - 1) / m * m; }

// Element-wise kernels over an nx x ny grid (or n cells) run in work-groups of one row of kRowGroup items
// (Kernel::launch_rows). PoCL's own choice for a NullRange local size made ewave_finish, ewave_prepare and
// ewave_propagate 20-35% slower on the CPU device.
inline constexpr size_t kRowGroup = 256;
inline const cl::NDRange kRowGroupRange{kRowGroup, 1};

template <typename... Args>
class Kernel {
 public:
  Kernel() = default;
  // Creates the kernel `name` of the built `program` and checks its signature against Args.
  Kernel(Runtime& runtime, const std::string& program, const std::string& name);

  // Sets every argument and enqueues global (local: cl::NullRange lets the device choose) on the calling
  // thread's queue. Must run under Runtime::exclusive(): the kernel object of each queue is shared by
  // every launch on that queue.
  template <typename... Given>
  void launch(const cl::NDRange& global, const cl::NDRange& local, const Given&... args) {
    launch_region(cl::NullRange, global, local, args...);
  }

  // The same over a part of the index space: ids offset .. offset + global - 1 (get_global_id includes
  // the offset).
  template <typename... Given>
  void launch_region(const cl::NDRange& offset, const cl::NDRange& global, const cl::NDRange& local,
                     const Given&... args) {
    static_assert(sizeof...(Given) == sizeof...(Args), "kernel launched with the wrong number of arguments");
    static_assert(KernelArgsMatch<std::tuple<Given...>, std::tuple<Args...>>::value,
                  "kernel argument types differ from the declared ones (cast to the exact cl_ type)");
    if (!runtime_) not_created();
    cl::Kernel& kernel = kernels_[current_queue_slot()];  // the calling thread's queue's
    cl_uint index = 0;
    (kernel.setArg(index++, args), ...);
    launch_kernel(*runtime_, kernel, program_, name_, offset, global, local, group_limit_);
  }

  // Exactly nx x ny work-items: the first nx - nx % kRowGroup columns in work-groups of one row of
  // kRowGroup items, the other columns in a second launch, one row of them a group. A kernel launched so
  // has no ids past the grid to skip. A bounds check masks every load and store of the loop that a CPU
  // device makes of a work-group, and LLVM turns masked strided accesses (interleaved complex values) into
  // AVX-512 gathers and scatters where unmasked ones become wide loads and shuffles.
  template <typename... Given>
  void launch_rows(size_t nx, size_t ny, const Given&... args) {
    const size_t whole = nx - nx % kRowGroup, rest = nx % kRowGroup;
    if (whole > 0 && ny > 0) launch(cl::NDRange(whole, ny), kRowGroupRange, args...);
    if (rest > 0 && ny > 0) launch_region(cl::NDRange(whole, 0), cl::NDRange(rest, ny), cl::NDRange(rest, 1), args...);
  }

  const std::string& name() const { return name_; }

 private:
  Runtime* runtime_ = nullptr;
  std::string program_, name_;
  std::vector<cl::Kernel> kernels_;  // one per device queue: launches on two queues at once set their own arguments
  size_t group_limit_ = 0;           // work_group_limit() of the kernel, asked once
};

template <typename... Args>
Kernel<Args...>::Kernel(Runtime& runtime, const std::string& program, const std::string& name)
    : runtime_(&runtime), program_(program), name_(name) {
  for (size_t i = 0; i < queue_count(runtime); ++i) kernels_.push_back(create_kernel(runtime, program, name));
  verify_kernel_args(kernels_.front(), program, name, {KernelArgTraits<Args>::spec...});
  group_limit_ = work_group_limit(runtime, kernels_.front());
}

}  // namespace squall

// Declares the by-value struct Type (host and device share the name) as a kernel argument type.
#define SQUALL_KERNEL_STRUCT(Type)                                           \
  namespace squall {                                                         \
  template <>                                                                \
  struct KernelArgTraits<Type> {                                             \
    static constexpr KernelArgSpec spec{KernelArgSpec::Kind::Struct, #Type}; \
  };                                                                         \
  }
