// eWave step kernels with a double state (see ewave/step_impl.clh), for devices with fp64. On a device
// without it the program is empty, and a session asking for double precision is refused.
#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#define real double
#define real2 double2
#define real3 double3
#define real4 double4
#include "ewave/step_impl.clh"
#endif
