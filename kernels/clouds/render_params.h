// Parameters of the cloud ray marcher (render.cl), shared by host C++ and OpenCL C.
// Layout: every member is a 4-byte int or float (arrays of them), so the struct has no padding and the
// same size and offsets on host and device (the host static_asserts the size). Passed by value.
#ifndef SQUALL_CLOUDS_RENDER_PARAMS_H
#define SQUALL_CLOUDS_RENDER_PARAMS_H

#define SQ_CLOUD_MAX_WAVELENGTHS 8
#define SQ_CLOUD_MAX_LIGHTS 4
#define SQ_CLOUD_MAX_SUBSTEPS 8

// phase
#define SQ_PHASE_UNIFORM 0          // 1/(4 pi)
#define SQ_PHASE_HG 1               // Henyey-Greenstein (g1), App D eq A.8
#define SQ_PHASE_DOUBLE_HG 2        // weight HG(g1) + (1 - weight) HG(g2)
#define SQ_PHASE_FOURNIER_FORAND 3  // App D eqs A.9-A.12 (ff_n, ff_mu = Junge slope 3.5..5)
// light kind
#define SQ_LIGHT_POINT 0
#define SQ_LIGHT_DIRECTIONAL 1
// shadow
#define SQ_SHADOW_NONE 0    // T^L = 1
#define SQ_SHADOW_DIRECT 1  // a secondary march toward each light per sample
#define SQ_SHADOW_DSM 2     // deep shadow map: column density toward each light on a box grid, trilinear

typedef struct sq_cloud_light {
  int kind;                                 // SQ_LIGHT_*
  float position[3];                        // point light, m
  float direction[3];                       // directional light: unit vector from the scene toward the light
  float intensity[SQ_CLOUD_MAX_WAVELENGTHS];  // point: spectral intensity (W sr^-1 m^-1); directional:
                                              // spectral irradiance (W m^-2 m^-1), per wavelength channel
} sq_cloud_light;

typedef struct sq_cloud_render {
  float eye[3];              // camera position, m
  float forward[3];          // unit view direction
  float right[3];            // unit, image +x
  float up[3];               // unit, image -y (row 0 is the top)
  float tan_half_fov_y;      // tan(vertical field of view / 2)
  int width, height;         // pixels
  float step;                // ray-march step Delta s, m
  int substeps;              // N_s random sub-steps per step, 1..SQ_CLOUD_MAX_SUBSTEPS
  int interpolation;         // 0 nearest voxel, 1 trilinear
  int seed;                  // jitter seed
  float min_transmittance;   // early termination threshold (0 = march to the end)
  int phase;                 // SQ_PHASE_*
  float g1, g2, weight;      // HG asymmetries and the double-HG weight of g1
  float ff_n, ff_mu;         // Fournier-Forand refractive index (> 1) and Junge slope mu
  int n_wavelengths;         // 1..SQ_CLOUD_MAX_WAVELENGTHS
  float wavelength[SQ_CLOUD_MAX_WAVELENGTHS];  // m (blackbody emission)
  float extinction[SQ_CLOUD_MAX_WAVELENGTHS];  // kappa, 1/m per unit density
  float albedo[SQ_CLOUD_MAX_WAVELENGTHS];      // single-scattering albedo, [0, 1]
  int has_temperature;       // emission C^E = (1 - albedo) kappa B_lambda(T) from the temperature grid
  int n_lights;              // 0..SQ_CLOUD_MAX_LIGHTS
  sq_cloud_light lights[SQ_CLOUD_MAX_LIGHTS];
  int shadow;                // SQ_SHADOW_*
  int dsm_n[3];              // deep shadow map nodes per axis (>= 2 each)
  float dsm_min[3];          // world box of the map, m
  float dsm_max[3];
} sq_cloud_render;

#endif
