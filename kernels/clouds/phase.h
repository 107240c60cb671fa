// Phase functions (appendix A of J. Tessendorf and M. Kowalski, "Resolution Independent Volumes" (SIGGRAPH
// course notes 2010/2011), reproduced as App. D of J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017); Gilligan sec. 7.2.1), normalized to 1 over the
// sphere. mu = cos(Theta) of the scattering angle between the view direction and the direction to the
// light; s2 = sin^2(Theta/2) = (1 - mu)/2 and c2 = cos^2(Theta/2) = (1 + mu)/2, passed separately because they
// are accurate near forward and backward scattering, where 1 - mu and 1 + mu are not.
#ifndef SQUALL_CLOUDS_PHASE_H
#define SQUALL_CLOUDS_PHASE_H

#define SQUALL_INV_4PI 0.0795774715459477f

// eq A.8, its denominator 1 + g^2 - 2 g mu written as (1 - g)^2 + 4 g s2 for g >= 0 and as (1 + g)^2 - 4 g c2
// for g < 0: sums of terms >= 0, accurate at the peak (forward for g > 0, backward for g < 0), where
// 1 - g^2 and 1 -+ mu would cancel
static inline float phase_hg(float s2, float c2, float g) {
  float d = g >= 0.0f ? (1.0f - g) * (1.0f - g) + 4.0f * g * s2 : (1.0f + g) * (1.0f + g) - 4.0f * g * c2;
  return SQUALL_INV_4PI * (1.0f - g * g) / (d * sqrt(d));
}

// A(p) / e^2 for e = 1 - delta, where A(p) = p e - (1 - delta^p) cancels to p (p - 1) e^2 / 2 + O(e^3): for
// |e| < 0.1 its binomial series to e^5 (c_0 = p (p - 1) / 2, c_(j+1) = -c_j (p - j - 2) / (j + 3); the
// first term left out is under 1e-6 of the sum), elsewhere with delta^p - 1 as expm1(p log delta), whose
// sum with p e then loses at most 2 / |e (p - 1)| ulps (80 at |e| = 0.1 and p = 3/4).
static inline float ff_bracket_part(float p, float delta, float e) {
  if (fabs(e) >= 0.1f) return (expm1(p * log(delta)) + p * e) / (e * e);
  float sum = 0.0f, c = 0.5f * p * (p - 1.0f), e_j = 1.0f;
  for (int j = 0; j < 6; ++j) {
    sum += c * e_j;
    c *= -(p - j - 2.0f) / (j + 3.0f);
    e_j *= e;
  }
  return sum;
}

// Fournier-Forand, eqs A.9-A.12, with the Junge slope mu_j in 3.5..5 and refractive index n (the caption of
// Fig A.2 prints mu = 0.35..0.5, a factor of 10 off: with those values it does not integrate to 1). With
// e = 1 - delta, A.9's bracket over (1 - delta)^2 is A(nu) / e^2 - A(nu + 1) / (s2 e^2), A as above (its
// second part, delta (1 - delta^nu) - nu e, is -A(nu + 1)): each part vanishes as e^2 where delta nears 1
// (sin^2(Theta/2) = 3 (n - 1)^2 / 4, a few degrees), and float would leave rounding over e^2 there, or 0 / 0.
static inline float phase_fournier_forand(float mu, float s2, float n, float mu_j) {
  float nu = (3.0f - mu_j) / 2.0f;
  float k = 4.0f / (3.0f * (n - 1.0f) * (n - 1.0f));
  s2 = fmax(s2, 1e-12f);
  float delta = k * s2, e = 1.0f - delta;
  float delta180 = k;
  float dnu = pow(delta, nu);
  float d180nu = pow(delta180, nu);
  float first = (ff_bracket_part(nu, delta, e) - ff_bracket_part(nu + 1.0f, delta, e) / s2) / (4.0f * M_PI_F * dnu);
  float second = (1.0f - d180nu) / (16.0f * M_PI_F * (delta180 - 1.0f) * d180nu) * (3.0f * mu * mu - 1.0f);
  return first + second;
}

static inline float phase_function(__private const CloudRenderParams* p, float mu, float s2, float c2) {
  if (p->phase == SQUALL_PHASE_HG) return phase_hg(s2, c2, p->g1);
  if (p->phase == SQUALL_PHASE_DOUBLE_HG)
    return p->weight * phase_hg(s2, c2, p->g1) + (1.0f - p->weight) * phase_hg(s2, c2, p->g2);
  if (p->phase == SQUALL_PHASE_FOURNIER_FORAND) return phase_fournier_forand(mu, s2, p->ff_n, p->ff_mu);
  return SQUALL_INV_4PI;
}

// Planck's spectral radiance B_lambda(T), W m^-2 sr^-1 m^-1 (lambda in m, T in K), evaluated as
// exp(ln(2hc^2/lambda^5) - x) / (1 - exp(-x)), x = hc/(lambda k T), which stays in float range where
// exp(x) alone would overflow (short wavelengths, cold clouds).
static inline float blackbody(float lambda, float T) {
  const float log_two_hc2 = -36.666532f;  // ln(2 h c^2 / (W m^2 sr^-1))
  const float hc_k = 1.43877688e-2f;      // h c / k, m K
  if (T <= 0.0f) return 0.0f;
  float x = hc_k / (lambda * T);
  return exp(log_two_hc2 - 5.0f * log(lambda) - x) / -expm1(-x);
}

#endif
