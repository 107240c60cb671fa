#include "textures/textures_support.h"

#include <algorithm>
#include <cmath>

#include "support/test_runtime.h"
#include "support/worst.h"
#include "textures/state_codec.h"

namespace squall::test {

using namespace squall::textures;

TextureEngine& texture_engine() {
  static LimitGate gate{Limits{}};
  static TextureEngine engine(runtime(), gate);
  return engine;
}

AdvectSpec noise_spec(Method method, int velocity_kind, std::vector<double> params, int size) {
  AdvectSpec spec;
  spec.method = method;
  spec.velocity.kind = velocity_kind;
  for (size_t k = 0; k < params.size(); ++k) spec.velocity.params[k] = params[k];
  spec.texture.kind = SQUALL_TEXTURE_NOISE;
  spec.texture.bands = 1;
  spec.texture.base_cells = 8;
  spec.texture.scale = 2;  // 16 noise cells across the domain
  spec.output = {size, size, 0, 0, 1, 1};
  spec.lagrangian.d = 12.0 / 128;
  spec.eulerian.grid_nx = spec.eulerian.grid_ny = 65;
  if (method == Method::TwoPhaseFlowMap) spec.eulerian.latencies = {1.0};
  return spec;
}

AdvectSpec cascade_spec(int velocity_kind, std::vector<double> params, double c_w) {
  AdvectSpec spec = noise_spec(Method::EulerianMultilayer, velocity_kind, std::move(params), 64);
  spec.texture.bands = 3;
  spec.texture.base_cells = 4;
  spec.texture.scale = 1;
  spec.eulerian.grid_nx = spec.eulerian.grid_ny = 32;
  spec.eulerian.cascade.c_w = c_w;
  return spec;
}

std::vector<float> cascade_of_checkpoint(const std::string& checkpoint) {
  StateReader in(checkpoint);  // the layout of Eulerian::checkpoint (eulerian.cpp)
  in.get<uint32_t>("the version");
  in.get<bool>("started");
  in.get<int64_t>("the frame index");
  in.get_vector<double>("the phase starts");
  in.get_vector<float>("the node state");
  return in.get_vector<float>("the cascade");
}

std::vector<TextureFrame> run(const AdvectSpec& spec, int frames) {
  AdvectSpec s = spec;
  s.frames = frames;
  texture_engine().validate(s, "spec");
  auto advection = texture_engine().start(s);
  std::vector<TextureFrame> out;
  for (int i = 0; i < frames; ++i) out.push_back(advection->next());
  return out;
}

Image plane_image(const TextureFrame& frame, int k) {
  const float* p = frame.plane(k);
  return Image{frame.width, frame.height, std::vector<float>(p, p + size_t(frame.width) * frame.height)};
}

double max_abs_difference(const TextureFrame& a, const TextureFrame& b, int k) {
  double worst = 0;
  const float *pa = a.plane(k), *pb = b.plane(k);
  for (size_t i = 0; i < size_t(a.width) * a.height; ++i)
    worst = squall::test::worse(worst, double(std::abs(pa[i] - pb[i])));
  return worst;
}

}  // namespace squall::test
