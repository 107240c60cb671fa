// OpenVDB -> NanoVDB, and the NanoVDB buffer uploaded to the device as is: the same data structure on host
// and device, transferred without conversion, as J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017), sec. 6.1, asks (its App. C, S. Bryce and Z. Welch,
// "Sparse Grid Volume Rendering on a GPU" (2012), details one such layout). Kernels read it through
// PNanoVDB.h (kernels/clouds/pnanovdb_cl.h).
#pragma once

#include <nanovdb/util/GridHandle.h>
#include <nanovdb/util/HostBuffer.h>
#include <openvdb/openvdb.h>

#include <cstdint>
#include <vector>

#include "runtime/runtime.h"

namespace squall::clouds {

using NanoHandle = nanovdb::GridHandle<nanovdb::HostBuffer>;

// nanovdb::openToNanoVDB of a float grid (same transform, values, active states and background).
NanoHandle to_nanovdb(const openvdb::FloatGrid& grid);

// A device copy of the handle's bytes (read-only, padded to whole 32-bit words).
cl::Buffer upload_nanovdb(Runtime& runtime, const NanoHandle& handle);

// A device copy of the words (read-only; one word, 0, for none).
cl::Buffer upload_words(Runtime& runtime, const std::vector<uint32_t>& words);

}  // namespace squall::clouds
