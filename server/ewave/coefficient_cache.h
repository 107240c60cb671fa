// The propagator tables of eWave steps on the device (propagator_coefficients, in the state's type), shared
// by every session of one grid, dispersion and dt: sessions stepping with the same config and a constant dt
// (a fleet of hulls, a client's sessions one after another) compute and upload one table between them, and
// a new session's first step finds it made. The least recently used tables are evicted past a byte budget,
// and the tables held count in the daemon's memory budget.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/limits.h"
#include "ewave/ewave_config.h"
#include "runtime/device_cache.h"
#include "runtime/runtime.h"

namespace squall::ewave {

class CoefficientCache {
 public:
  // 64 MiB: 127 tables of a 256^2 single-precision grid, 3 of 1024^2 in double precision.
  static constexpr size_t kDefaultMaxBytes = size_t(64) << 20;
  // Tables beyond `max_bytes` evict the least recently used; one larger than `max_bytes` is returned but
  // not kept. Each table kept holds its bytes in `gate`'s memory budget (none: not counted): where the
  // budget has no room for a new one, the least recently used give theirs, and where even all of theirs
  // would not make room it is returned but not kept (the others stay).
  explicit CoefficientCache(size_t max_bytes = kDefaultMaxBytes, LimitGate* gate = nullptr)
      : tables_(max_bytes, gate, "an eWave propagator table kept for the next steps") {}

  // The table of (config, dt), computed on a miss into a buffer whose contents are complete when it is
  // returned (no command: any queue may read it). Thread-safe, and no device queue is needed: a miss is
  // computed with no lock held, and callers missing the same table meanwhile wait for it, not for others.
  cl::Buffer get(const Runtime& runtime, const EWaveConfig& config, double dt);

  // The bytes of one table of `config`: four values per mode of its half spectrum, in the state's type.
  static size_t table_bytes(const EWaveConfig& config);

  uint64_t computed() const { return tables_.computed(); }  // tables computed so far
  size_t max_bytes() const { return tables_.max_bytes(); }  // a larger table is not kept
  size_t bytes() const { return tables_.bytes(); }          // held now

 private:
  // What propagator_coefficients() and the state's type depend on.
  struct Key {
    int64_t nx = 0, ny = 0;
    double length_x = 0, length_y = 0, gravity = 0, depth = 0, capillary_length = 0, dt = 0;
    int dispersion = 0;
    bool double_precision = false;
    bool operator==(const Key&) const = default;
  };
  static Key key_of(const EWaveConfig& config, double dt);

  DeviceCache<Key> tables_;
};

}  // namespace squall::ewave
