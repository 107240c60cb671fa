// Evolution of a cloud (J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering
// Maritime Environments" (2017), sec. 6.4): the model's parameters change linearly with time, so a stream of
// frames shows the cloud evolving. Items of §6.4: (1) the base shape moves, (2) the pyroclastic noise
// and amplitude change, (3) the stamping noise changes, (4) the advection time grows, (5) the velocity
// field evolves (its noise pattern moves).
#pragma once

#include <string>

#include "clouds/model.h"

namespace squall::clouds {

struct Evolution {
  Vec3d drift{0, 0, 0};           // m/s: spheres, ellipsoids, meshes and particles translate (1)
  Vec3d noise_drift{0, 0, 0};     // m/s: the pyroclastic, stamping and temperature noise patterns move (2, 3)
  double amplitude_rate = 0;      // m/s: pyroclastic amplitude growth (2); the amplitude stays >= 0
  double advection_rate = 0;      // s/s, >= 0: advection time added per second (4)
  Vec3d velocity_drift{0, 0, 0};  // m/s: the velocity noise pattern moves (5)
};

// Throws squall::Error(InvalidArgument) naming the field for non-finite or out-of-range values.
void validate(const Evolution& evolution, const std::string& prefix = "evolution");

// The model at time t (s) after `base`. A pattern moving with velocity v is sampled at x - v t.
CloudModel model_at(const CloudModel& base, const Evolution& evolution, double t);

}  // namespace squall::clouds
