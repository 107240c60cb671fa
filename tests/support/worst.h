// The running worst of a test's errors, where a NaN stays once met: std::max(worst, NaN) is worst (and
// std::max({...}) drops a NaN after its first element), so a test of max |error| < tolerance passed on
// output that was all NaN.
#pragma once

#include <cmath>

namespace squall::test {

template <typename... Errors>
double worse(double worst, Errors... errors) {
  for (double error : {double(errors)...})
    if (!std::isnan(worst) && !(error <= worst)) worst = error;
  return worst;
}

// The same for scores where lower is worse (a PSNR): the running lowest, a NaN kept once met.
template <typename... Scores>
double lowest(double worst, Scores... scores) {
  return -worse(-worst, -double(scores)...);
}

}  // namespace squall::test
