// eWave step kernels with a float state (see ewave/step_impl.clh).
#define real float
#define real2 float2
#define real3 float3
#define real4 float4
#include "ewave/step_impl.clh"
