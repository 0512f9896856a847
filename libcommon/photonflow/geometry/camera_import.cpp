// The camera of a bake: the file's first camera in world space, and the camera the options,
// that camera or the default framing give (read_camera, resolve_camera, scene_import_internal.h).
//
// Camera. assimp's camera.h documents mHorizontalFOV as the half angle, but the loaders store the
// full angle: the COLLADA loader copies <xfov> (the full horizontal angle of the COLLADA spec)
// converted to radians, verified with <xfov>60</xfov> → 1.0472; glTF and FBX store full angles
// too. It is therefore read as the full horizontal angle and converted to the vertical one with
// the camera's aspect (mAspect, or width/height when the file has none). Two loader quirks of
// assimp 5.2.5 are compensated: glTF stores yfov·aspect (not the exact 2·atan(aspect·tan(yfov/2)))
// as the horizontal angle, which is accepted as is (a small error for wide cameras), and glTF
// copies the camera node's translation into aiCamera::mPosition although the node keeps it too,
// so the position is taken from the node alone for .gltf/.glb files.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/camera.h"
#include "photonflow/geometry/scene_import_internal.h"
#include "photonflow/geometry/scene_inputs.h"

namespace pf::import {

namespace {

constexpr float kPi = 3.14159265358979323846f;

}  // namespace

std::optional<FileCamera> read_camera(const aiScene& ai, const std::string& file,
                                      BakeReport& report) {
  if (ai.mNumCameras == 0) return std::nullopt;
  const aiCamera& c = *ai.mCameras[0];
  const aiNode* node = ai.mRootNode->FindNode(c.mName);
  const aiMatrix4x4 m = node ? global_transform(node) : aiMatrix4x4();
  const aiMatrix3x3 lin(m);
  const std::string ext = lower_extension(file);
  const bool gltf = ext == ".gltf" || ext == ".glb";
  FileCamera fc;
  fc.eye = to_vec(m * (gltf ? aiVector3D(0, 0, 0) : c.mPosition));
  fc.dir = normalize(to_vec(lin * c.mLookAt));
  fc.up = normalize(to_vec(lin * c.mUp));
  fc.fov_x_rad = c.mHorizontalFOV;
  fc.aspect = c.mAspect;
  if (!(fc.fov_x_rad > 0.f && fc.fov_x_rad < kPi)) {
    // A glTF orthographic camera (no angle) has its own line already (gltf_features.h).
    if (!(gltf && c.mOrthographicWidth > 0.f))
      report.warnings.push_back(file + ": camera '" + std::string(c.mName.C_Str()) +
                                "' has no usable perspective angle; using " +
                                fmt_float(kDefaultFovYDeg) + " degrees vertical");
    fc.fov_x_rad = 0;
  }
  return fc;
}

pf_camera resolve_camera(const BakeOptions& o, const std::optional<FileCamera>& fc,
                         const Bounds& bounds, const std::string& file) {
  const float file_aspect = fc && fc->aspect > 0.f ? fc->aspect : 0.f;
  const float base_aspect = file_aspect > 0.f ? file_aspect : 1.f;
  if (o.width < 0 || o.height < 0 || o.width > kMaxImageSide || o.height > kMaxImageSide)
    throw input_error(file, "image size " + std::to_string(o.width) + "x" +
                                std::to_string(o.height) + " is out of range",
                      "give --width and --height in pixels, 1.." + std::to_string(kMaxImageSide));
  pf_camera cam{};
  cam.width = o.width;
  cam.height = o.height;
  if (!cam.width && !cam.height) cam.width = kDefaultImageSize;
  if (!cam.height) cam.height = std::max(1, int(std::lround(cam.width / base_aspect)));
  if (!cam.width) cam.width = std::max(1, int(std::lround(cam.height * base_aspect)));
  const float image_aspect = float(cam.width) / float(cam.height);

  float fov_y = kDefaultFovYDeg;
  if (o.fov_y_deg) {
    fov_y = *o.fov_y_deg;
  } else if (fc && fc->fov_x_rad > 0.f) {
    const float a = file_aspect > 0.f ? file_aspect : image_aspect;
    fov_y = 2.f * std::atan(std::tan(0.5f * fc->fov_x_rad) / a) * 180.f / kPi;
  }
  if (!(fov_y > 0.f && fov_y < 180.f))
    throw input_error(file, "vertical field of view " + fmt_float(fov_y) +
                                " is outside (0, 180) degrees",
                      "give --fov in degrees");
  cam.fov_y_deg = fov_y;

  Vec3 eye, look_at, up(0, 1, 0);
  if (fc) {
    eye = fc->eye;
    look_at = fc->eye + fc->dir;
    up = fc->up;
  } else {
    const float half_y = 0.5f * fov_y * kPi / 180.f;
    const float half_x = std::atan(std::tan(half_y) * image_aspect);
    const float radius = 0.5f * length(bounds.extent());
    const float dist = radius / std::sin(std::min(half_x, half_y));
    look_at = bounds.center();
    eye = look_at + Vec3(0, 0, dist);
  }
  if (o.eye) eye = *o.eye;
  if (o.look_at) look_at = *o.look_at;
  if (o.up) up = *o.up;
  const Vec3 dir = look_at - eye;
  // A direction from two points closer than float rounding of the scene's coordinates is noise
  // (an --eye typed onto the file's look-at point by its printed digits): refused, not normalised.
  const float min_dist = 1e-5f * std::max({1.f, length(bounds.extent()), length(eye)});
  if (!finite(eye) || !finite(look_at) || !finite(up) || !(length(dir) > min_dist))
    throw input_error(file, "camera eye " + fmt_vec(eye) + " and look-at " + fmt_vec(look_at) +
                                " do not give a view direction",
                      "give distinct finite --eye and --look-at");
  if (!(length(cross(normalize(dir), normalize(up))) > 1e-4f))
    throw input_error(file, "camera up " + fmt_vec(up) + " is parallel to the view direction",
                      "give an --up that is not along the view");
  eye.store(cam.eye);
  look_at.store(cam.look_at);
  normalize(up).store(cam.up);
  // Thin lens: focused on the look-at point unless --focus-distance says otherwise.
  if (o.aperture > 0.f) {
    cam.aperture = o.aperture;
    cam.focus_distance = o.focus_distance ? *o.focus_distance : length(dir);
    if (const char* why = camera_lens_problem(cam.aperture, cam.focus_distance))
      throw input_error(file, why, "give --aperture and --focus-distance in scene units");
  }
  return cam;
}

std::string camera_sources(const BakeOptions& o, const std::optional<FileCamera>& fc) {
  const bool file_fov = fc && fc->fov_x_rad > 0.f;  // an unusable angle: the default 40 degrees
  const std::pair<const char*, int> values[] = {
      {"eye", o.eye ? 0 : fc ? 1 : 2},
      {"look-at", o.look_at ? 0 : fc ? 1 : 2},
      {"up", o.up ? 0 : fc ? 1 : 2},
      {"fov", o.fov_y_deg ? 0 : file_fov ? 1 : 2}};
  const char* from[3] = {" from options", " from file", " from default framing"};
  std::string out;
  for (int src = 0; src < 3; ++src) {
    std::string names;
    for (const auto& [name, s] : values)
      if (s == src) names += (names.empty() ? "" : ", ") + std::string(name);
    if (!names.empty()) out += (out.empty() ? "" : "; ") + names + from[src];
  }
  return out;
}

}  // namespace pf::import
