// FFTW's single-precision wisdom as text: what its planner has measured so far in this process. Every
// plan FFTW measures adds to it, and a plan it already knows does not, so a transform that plans nothing
// leaves it unchanged.
#pragma once

#include <fftw3.h>

#include <cstdlib>
#include <memory>
#include <string>

namespace squall::test {

inline std::string fftwf_wisdom() {
  const std::unique_ptr<char, decltype(&std::free)> text(fftwf_export_wisdom_to_string(), &std::free);
  return text ? std::string(text.get()) : std::string();
}

}  // namespace squall::test
