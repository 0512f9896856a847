// camera.h — camera rays (pf_camera in shared_types.h): a pinhole, or a thin lens for depth of
// field (material/lens_shared.h, the code the OpenCL eye pass runs too).
//
// The camera looks from `eye` towards `look_at`; the image's +x is the camera's right, +y is down
// (row 0 at the top). fov_y_deg is the full vertical field of view; pixels are square. With
// aperture a > 0 a ray leaves a point of the lens disc of radius a (in the plane of right and up,
// centred on the eye) towards the point where the pinhole ray meets the focus plane at distance
// focus_distance along the view axis: that plane is sharp, a point at depth z is blurred over the
// circle of confusion 2a|z − d|/z (measured on the focus plane).
#pragma once
#include <cmath>

#include "photonflow/material/lens_shared.h"
#include "photonflow/foundations/shared_types.h"
#include "photonflow/foundations/vec.h"

namespace pf {

// Largest image side in pixels: scene-bake's --width and --height, scene.h5's camera and the
// stage files' width/height attributes are checked against it (every image buffer is sized by
// them).
constexpr int kMaxImageSide = 65536;

// Largest lens radius and focus distance (world units), as --radius's bound (validate.h):
// beyond it lens points lose the scene's float resolution.
constexpr float kMaxLensLength = 1e12f;

// Why (aperture, focus_distance) is not a camera lens, or nullptr: a pinhole is (0, 0); a thin
// lens has both in (0, kMaxLensLength].
inline const char* camera_lens_problem(float aperture, float focus_distance) {
  if (aperture == 0.f && focus_distance == 0.f) return nullptr;
  if (!(aperture >= 0.f && aperture <= kMaxLensLength))
    return "the lens radius must be 0 (pinhole) or in (0, 1e12] world units";
  if (aperture == 0.f) return "a pinhole camera (aperture 0) has focus distance 0";
  if (!(focus_distance > 0.f && focus_distance <= kMaxLensLength))
    return "the focus distance of a lens must be in (0, 1e12] world units";
  return nullptr;
}

class CameraFrame {
 public:
  explicit CameraFrame(const pf_camera& c)
      : width_(c.width), height_(c.height), aperture_(c.aperture),
        focus_distance_(c.focus_distance) {
    eye_ = Vec3(c.eye);
    forward_ = normalize(Vec3(c.look_at) - eye_);
    right_ = normalize(cross(forward_, Vec3(c.up)));
    up_ = cross(right_, forward_);
    tan_half_y_ = std::tan(0.5f * c.fov_y_deg * 3.14159265358979f / 180.f);
    tan_half_x_ = tan_half_y_ * float(c.width) / float(c.height);
  }
  // Unit direction through image position (px, py) in pixels: (0,0) is the top-left corner of the
  // image, (width, height) the bottom-right; a pixel's centre is (x + 0.5, y + 0.5).
  Vec3 direction(float px, float py) const {
    float sx = (2.f * px / float(width_) - 1.f) * tan_half_x_;
    float sy = (1.f - 2.f * py / float(height_)) * tan_half_y_;
    return normalize(forward_ + right_ * sx + up_ * sy);
  }
  // The camera ray through image position (px, py) and lens sample (u1, u2) in [0, 1)²: from the
  // eye along direction(px, py) for a pinhole; from the lens point towards the focus plane's point
  // for a thin lens (pf_thin_lens_ray, lens_shared.h). `dir` comes back unit.
  void ray(float px, float py, float u1, float u2, Vec3& origin, Vec3& dir) const {
    const Vec3 d = direction(px, py);
    if (!lens()) {
      origin = eye_;
      dir = d;
      return;
    }
    float o[3], dd[3], r[3], u[3], f[3], oo[3], od[3];
    eye_.store(o);
    d.store(dd);
    right_.store(r);
    up_.store(u);
    forward_.store(f);
    pf_thin_lens_ray(o, dd, r, u, f, aperture_, focus_distance_, u1, u2, oo, od);
    origin = Vec3(oo);
    dir = Vec3(od);
  }
  bool lens() const { return aperture_ > 0.f; }
  float aperture() const { return aperture_; }
  float focus_distance() const { return focus_distance_; }
  const Vec3& eye() const { return eye_; }
  const Vec3& forward() const { return forward_; }
  const Vec3& right() const { return right_; }
  const Vec3& up() const { return up_; }
  float tan_half_x() const { return tan_half_x_; }
  float tan_half_y() const { return tan_half_y_; }
  int width() const { return width_; }
  int height() const { return height_; }
  // Area of the image plane at distance 1 covered by one pixel (for pixel footprints).
  float pixel_angle() const { return 2.f * tan_half_y_ / float(height_); }

 private:
  Vec3 eye_, forward_, right_, up_;
  float tan_half_x_, tan_half_y_;
  int width_, height_;
  float aperture_, focus_distance_;
};

// True when the camera is usable: finite vectors, eye != look_at, up not parallel to the view,
// 0 < fov < 180, positive size. `why` gets the reason when false.
inline bool camera_valid(const pf_camera& c, const char** why) {
  Vec3 e(c.eye), l(c.look_at), u(c.up);
  if (!finite(e) || !finite(l) || !finite(u)) return *why = "camera vectors must be finite", false;
  if (length(l - e) <= 0.f) return *why = "camera eye and look-at coincide", false;
  if (length(cross(normalize(l - e), u)) < 1e-6f)
    return *why = "camera up is parallel to the view direction", false;
  if (!(c.fov_y_deg > 0.f && c.fov_y_deg < 180.f))
    return *why = "camera fov must be in (0, 180) degrees", false;
  if (c.width <= 0 || c.height <= 0) return *why = "image width and height must be positive", false;
  if (const char* lens = camera_lens_problem(c.aperture, c.focus_distance)) return *why = lens, false;
  return true;
}

}  // namespace pf
