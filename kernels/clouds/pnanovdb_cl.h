// PNanoVDB.h (libnanovdb-dev, embedded by kernels/CMakeLists.txt under "nanovdb/PNanoVDB.h") in OpenCL C.
// Include this header, never PNanoVDB.h directly. It is OpenCL C 1.2: PNanoVDB.h's pointers are to private
// structs (unqualified pointers are __private in 1.2), and its program-scope tables are embedded as
// __constant arrays (kernels/embed.cmake), so no device needs OpenCL C 2.0's generic address space.
//
// What this header supplies in place of the libc headers PNanoVDB.h would include (blanked at embed time):
//   stdint.h: uint32_t, int32_t, uint64_t, int64_t as OpenCL's uint, int, ulong, long;
//   string.h: pnanovdb_memcpy, only used to reinterpret bits (as_float / as_double in OpenCL C);
//   math.h:   floorf, used by the HDDA helpers.
// The buffer is PNANOVDB_BUF_CUSTOM: a NanoVDB grid uploaded byte for byte into a __global uint buffer,
// addressed with 64-bit byte offsets (PNANOVDB_ADDRESS_64).
#ifndef SQUALL_CLOUDS_PNANOVDB_CL_H
#define SQUALL_CLOUDS_PNANOVDB_CL_H

typedef uint uint32_t;
typedef int int32_t;
typedef ulong uint64_t;
typedef long int64_t;
#define floorf floor

#define PNANOVDB_C
#define PNANOVDB_ADDRESS_64
#define PNANOVDB_BUF_CUSTOM
#define PNANOVDB_MEMCPY_CUSTOM
#define PNANOVDB_HDDA
#define pnanovdb_memcpy(dst, src, n) __builtin_memcpy(dst, src, n)

typedef struct pnanovdb_buf_t {
  __global const uint* data;
} pnanovdb_buf_t;

static inline pnanovdb_buf_t pnanovdb_make_buf(__global const uint* data) {
  pnanovdb_buf_t buf;
  buf.data = data;
  return buf;
}
static inline uint pnanovdb_buf_read_uint32(pnanovdb_buf_t buf, ulong byte_offset) {
  return buf.data[byte_offset >> 2];
}
static inline ulong pnanovdb_buf_read_uint64(pnanovdb_buf_t buf, ulong byte_offset) {
  ulong word = byte_offset >> 2;
  return (ulong)buf.data[word] | ((ulong)buf.data[word + 1] << 32);
}
typedef uint pnanovdb_grid_type_t;
#define PNANOVDB_GRID_TYPE_GET(grid_typeIn, nameIn) pnanovdb_grid_type_constants[grid_typeIn].nameIn

#include "nanovdb/PNanoVDB.h"

// The read accessor of the first grid in buf (a NanoVDB buffer holds one grid per upload in squall).
static inline pnanovdb_readaccessor_t sq_vdb_accessor(pnanovdb_buf_t buf) {
  pnanovdb_grid_handle_t grid;
  grid.address.byte_offset = 0;
  pnanovdb_root_handle_t root = pnanovdb_tree_get_root(buf, pnanovdb_grid_get_tree(buf, grid));
  pnanovdb_readaccessor_t acc;
  pnanovdb_readaccessor_init(&acc, root);
  return acc;
}

// The float value at voxel ijk (the background outside the active set).
static inline float sq_vdb_value(pnanovdb_buf_t buf, pnanovdb_readaccessor_t* acc, int3 ijk) {
  pnanovdb_coord_t c;
  c.x = ijk.x;
  c.y = ijk.y;
  c.z = ijk.z;
  return pnanovdb_read_float(buf, pnanovdb_readaccessor_get_value_address(PNANOVDB_GRID_TYPE_FLOAT, buf, acc, &c));
}

#endif
