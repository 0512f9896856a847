// environment.h — the environment light on the host: the map a bake reads (an equirectangular
// .exr or .hdr file, or a constant colour), its checks, its power, and the packed buffer of
// environment_shared.h (texels, the sampling distribution) that the host and the kernels sample.
// docs/SCENES.md "Environment", docs/FORMATS.md (scene.h5 /environment).
#pragma once
#include <string>
#include <vector>

#include "photonflow/foundations/vec.h"

namespace pf {

// Largest accepted map: 8192 × 4096 texels (each 3 floats of radiance plus about 2 floats of
// sampling tables: about 670 MiB in memory, on the device and, for the texels, in scene.h5).
constexpr int kMaxEnvironmentWidth = 8192;
// The map of a constant colour: this many columns (and half as many rows) of one value, so that
// sampling by luminance × sin θ is close to uniform on the sphere.
constexpr int kConstantEnvironmentWidth = 64;

struct Environment {
  int width = 0, height = 0;     // texels; 0 = no environment; width = 2·height
  std::vector<float> texels;     // RGB radiance, W/(sr m²) before strength, row 0 = the top (v = 0)
  float strength = 1.f;          // radiance scale (--environment-strength)
  float rotation_deg = 0.f;      // rotation about +y, degrees (--environment-rotate)
  std::string source;            // the map file as given, or "constant R,G,B"

  bool present() const { return width > 0; }
};

// The environment of the bake option --environment TEXT: "R,G,B" (three numbers) is a constant
// colour (kConstantEnvironmentWidth map), anything else a .exr or .hdr file
// (read_radiance_image). InputError, one line naming the file or the option, for a file that
// cannot be read or is not a 2:1 map within kMaxEnvironmentWidth, and for texels or a colour that
// are not finite and ≥ 0 (check_environment), or a map that sends no light.
Environment load_environment(const std::string& text, float strength, float rotation_deg);

// "R,G,B": three numbers, each to its last character (written to rgb); false for anything else
// (a file name).
bool parse_environment_colour(const std::string& text, float rgb[3]);

// Checks an environment (every reader: load_environment, load_scene): shape 2:1 within the
// bound, texels.size() = 3·W·H, every texel finite and ≥ 0, strength finite and > 0, rotation
// finite, and some light (a texel with luminance > 0). InputError naming `file` and `what`.
void check_environment(const Environment& env, const std::string& file, const std::string& what);

// ∫ luminance(L(ω)) dω over the sphere, L = strength·texel (texel-constant: the sum of texel
// luminance × the texel's solid angle (2π/W)(cos θ_j − cos θ_{j+1})), in double.
double environment_luminance_integral(const Environment& env);

// The packed buffer of environment_shared.h for `env` (empty env: the header alone, width 0),
// around the bounding sphere (centre, radius), the environment being light `light` with pick
// probability p_pick (−1 and 0 without). The distribution's tables are computed in double and
// stored as float, the CDFs ending in exactly 1.
std::vector<float> pack_environment(const Environment& env, const Vec3& centre, float radius,
                                    int light, float p_pick);

}  // namespace pf
