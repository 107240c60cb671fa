// Parameters of the cloud ray marcher (render.cl), shared by host C++ and OpenCL C.
// Layout: every member is a 4-byte int or float (arrays of them), so the struct has no padding and the
// same size and offsets on host and device; the asserts at the end (host C++ only) are its offset table.
// Passed by value.
#ifndef SQUALL_CLOUDS_RENDER_PARAMS_H
#define SQUALL_CLOUDS_RENDER_PARAMS_H

#define SQUALL_CLOUD_MAX_WAVELENGTHS 8
#define SQUALL_CLOUD_MAX_LIGHTS 4
#define SQUALL_CLOUD_MAX_SUBSTEPS 8
// Equiangular samples of a point light per half turn seen from it along a primary ray (render.cl's
// sq_point_light_inscatter): at most 4 / pi times this many more than one a sub-step, per ray and point light.
#define SQUALL_CLOUD_POINT_LIGHT_STRATA 64

// phase (App D: J. Tessendorf and M. Kowalski, "Resolution Independent Volumes" (SIGGRAPH course notes
// 2010/2011), appendix A, reproduced as App. D of J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017))
#define SQUALL_PHASE_UNIFORM 0          // 1/(4 pi)
#define SQUALL_PHASE_HG 1               // Henyey-Greenstein (g1), App D eq A.8
#define SQUALL_PHASE_DOUBLE_HG 2        // weight HG(g1) + (1 - weight) HG(g2)
#define SQUALL_PHASE_FOURNIER_FORAND 3  // App D eqs A.9-A.12 (ff_n, ff_mu = Junge slope 3.5..5)
// light kind
#define SQUALL_LIGHT_POINT 0
#define SQUALL_LIGHT_DIRECTIONAL 1
// shadow
#define SQUALL_SHADOW_NONE 0    // T^L = 1
#define SQUALL_SHADOW_DIRECT 1  // a secondary march toward each light per sample
#define SQUALL_SHADOW_DSM 2     // deep shadow map: column density toward each light on a box grid, trilinear

typedef struct CloudLight {
  int kind;                                       // SQUALL_LIGHT_*
  float position[3];                              // point light, m
  float direction[3];                             // directional light: unit vector from the scene toward the light
  float intensity[SQUALL_CLOUD_MAX_WAVELENGTHS];  // point: spectral intensity (W sr^-1 m^-1); directional:
                                                  // spectral irradiance (W m^-2 m^-1), per wavelength channel
} CloudLight;

typedef struct CloudRenderParams {
  float eye[3];                                    // camera position, m
  float forward[3];                                // unit view direction
  float right[3];                                  // unit, image +x
  float up[3];                                     // unit, image -y (row 0 is the top)
  float tan_half_fov_y;                            // tan(vertical field of view / 2)
  int width, height;                               // pixels
  float step;                                      // ray-march step Delta s, m
  int substeps;                                    // N_s random sub-steps per step, 1..SQUALL_CLOUD_MAX_SUBSTEPS
  int interpolation;                               // 0 nearest voxel, 1 trilinear
  int seed;                                        // jitter seed
  float min_transmittance;                         // early termination threshold (0 = march to the end)
  int phase;                                       // SQUALL_PHASE_*
  float g1, g2, weight;                            // HG asymmetries and the double-HG weight of g1
  float ff_n, ff_mu;                               // Fournier-Forand refractive index (> 1) and Junge slope mu
  int n_wavelengths;                               // 1..SQUALL_CLOUD_MAX_WAVELENGTHS
  float wavelength[SQUALL_CLOUD_MAX_WAVELENGTHS];  // m (blackbody emission)
  float extinction[SQUALL_CLOUD_MAX_WAVELENGTHS];  // kappa, 1/m per unit density
  float albedo[SQUALL_CLOUD_MAX_WAVELENGTHS];      // single-scattering albedo, [0, 1]
  int has_temperature;  // emission C^E = (1 - albedo) kappa B_lambda(T) from the temperature grid
  int n_lights;         // 0..SQUALL_CLOUD_MAX_LIGHTS
  CloudLight lights[SQUALL_CLOUD_MAX_LIGHTS];
  int shadow;        // SQUALL_SHADOW_*
  int dsm_n[3];      // deep shadow map nodes per axis (>= 2 each)
  float dsm_min[3];  // world box of the map, m
  float dsm_max[3];
  float shadow_step;        // step of the marches toward the lights (direct shadows, deep shadow map), m
  float shadow_column_max;  // a shadow march stops past this column density, m (-ln(min_transmittance) /
                            // the smallest extinction); FLT_MAX: never
  int shadow_interpolation;  // density on the shadow marches: 0 nearest voxel, 1 trilinear
  float point_light_radius;  // m, > 0: a point light's irradiance I / max(d, radius)^2 (half the grid's voxel)
} CloudRenderParams;

#ifdef __cplusplus
#include "common/host_layout.h"
SQUALL_ASSERT_SIZE(CloudLight, 60);
SQUALL_ASSERT_OFFSET(CloudLight, kind, 0);
SQUALL_ASSERT_OFFSET(CloudLight, position, 4);
SQUALL_ASSERT_OFFSET(CloudLight, direction, 16);
SQUALL_ASSERT_OFFSET(CloudLight, intensity, 28);
SQUALL_ASSERT_SIZE(CloudRenderParams, 508);
SQUALL_ASSERT_OFFSET(CloudRenderParams, eye, 0);
SQUALL_ASSERT_OFFSET(CloudRenderParams, forward, 12);
SQUALL_ASSERT_OFFSET(CloudRenderParams, right, 24);
SQUALL_ASSERT_OFFSET(CloudRenderParams, up, 36);
SQUALL_ASSERT_OFFSET(CloudRenderParams, tan_half_fov_y, 48);
SQUALL_ASSERT_OFFSET(CloudRenderParams, width, 52);
SQUALL_ASSERT_OFFSET(CloudRenderParams, height, 56);
SQUALL_ASSERT_OFFSET(CloudRenderParams, step, 60);
SQUALL_ASSERT_OFFSET(CloudRenderParams, substeps, 64);
SQUALL_ASSERT_OFFSET(CloudRenderParams, interpolation, 68);
SQUALL_ASSERT_OFFSET(CloudRenderParams, seed, 72);
SQUALL_ASSERT_OFFSET(CloudRenderParams, min_transmittance, 76);
SQUALL_ASSERT_OFFSET(CloudRenderParams, phase, 80);
SQUALL_ASSERT_OFFSET(CloudRenderParams, g1, 84);
SQUALL_ASSERT_OFFSET(CloudRenderParams, g2, 88);
SQUALL_ASSERT_OFFSET(CloudRenderParams, weight, 92);
SQUALL_ASSERT_OFFSET(CloudRenderParams, ff_n, 96);
SQUALL_ASSERT_OFFSET(CloudRenderParams, ff_mu, 100);
SQUALL_ASSERT_OFFSET(CloudRenderParams, n_wavelengths, 104);
SQUALL_ASSERT_OFFSET(CloudRenderParams, wavelength, 108);
SQUALL_ASSERT_OFFSET(CloudRenderParams, extinction, 140);
SQUALL_ASSERT_OFFSET(CloudRenderParams, albedo, 172);
SQUALL_ASSERT_OFFSET(CloudRenderParams, has_temperature, 204);
SQUALL_ASSERT_OFFSET(CloudRenderParams, n_lights, 208);
SQUALL_ASSERT_OFFSET(CloudRenderParams, lights, 212);
SQUALL_ASSERT_OFFSET(CloudRenderParams, shadow, 452);
SQUALL_ASSERT_OFFSET(CloudRenderParams, dsm_n, 456);
SQUALL_ASSERT_OFFSET(CloudRenderParams, dsm_min, 468);
SQUALL_ASSERT_OFFSET(CloudRenderParams, dsm_max, 480);
SQUALL_ASSERT_OFFSET(CloudRenderParams, shadow_step, 492);
SQUALL_ASSERT_OFFSET(CloudRenderParams, shadow_column_max, 496);
SQUALL_ASSERT_OFFSET(CloudRenderParams, shadow_interpolation, 500);
SQUALL_ASSERT_OFFSET(CloudRenderParams, point_light_radius, 504);
#endif

#endif
