/* Host-side (C++) checks of the layout of the structs shared by host and kernels: each shared header
 * includes this under __cplusplus and asserts the size and every member's offset of its structs, so a
 * host compiler that lays one out differently from its documented table (and from OpenCL C) stops the
 * build. The OpenCL compiler skips it. It includes no system header (KernelSources splices it into kernel
 * programs, which have none): __builtin_offsetof is what offsetof of <cstddef> expands to in GCC and
 * Clang. */
#ifndef SQUALL_COMMON_HOST_LAYOUT_H
#define SQUALL_COMMON_HOST_LAYOUT_H

#define SQUALL_ASSERT_SIZE(Type, bytes) static_assert(sizeof(Type) == (bytes), "sizeof(" #Type ") must be " #bytes)
#define SQUALL_ASSERT_OFFSET(Type, member, offset) \
  static_assert(__builtin_offsetof(Type, member) == (offset), #Type "." #member " must be at offset " #offset)

#endif
