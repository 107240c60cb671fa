#include "ewave/coefficient_cache.h"

#include <vector>

#include "ewave/ewave_state_format.h"
#include "ewave/propagator.h"

namespace squall::ewave {

CoefficientCache::Key CoefficientCache::key_of(const EWaveConfig& c, double dt) {
  Key k;
  k.nx = c.nx, k.ny = c.ny;
  k.length_x = c.length_x(), k.length_y = c.length_y();
  k.gravity = c.gravity, k.depth = c.depth, k.capillary_length = c.capillary_length;
  k.dt = dt;
  k.dispersion = int(c.dispersion);
  k.double_precision = c.double_precision;
  return k;
}

size_t CoefficientCache::table_bytes(const EWaveConfig& c) {
  return 4 * (size_t(c.nx) / 2 + 1) * size_t(c.ny) * (c.double_precision ? sizeof(double) : sizeof(float));
}

cl::Buffer CoefficientCache::get(const Runtime& runtime, const EWaveConfig& config, double dt) {
  return tables_.get(key_of(config, dt), [&] {
    std::vector<char> table = to_state_type(propagator_coefficients(config, dt), config.double_precision);
    cl::Buffer buffer(runtime.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, table.size(), table.data());
    return DeviceCache<Key>::Made{buffer, table.size()};
  });
}

}  // namespace squall::ewave
