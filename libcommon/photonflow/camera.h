// camera.h — pinhole camera rays (pf_camera in shared_types.h).
//
// The camera looks from `eye` towards `look_at`; the image's +x is the camera's right, +y is down
// (row 0 at the top). fov_y_deg is the full vertical field of view; pixels are square.
#pragma once
#include <cmath>

#include "photonflow/shared_types.h"
#include "photonflow/vec.h"

namespace pf {

// Largest image side in pixels: scene-bake's --width and --height, scene.h5's camera and the
// stage files' width/height attributes are checked against it (every image buffer is sized by
// them).
constexpr int kMaxImageSide = 65536;

class CameraFrame {
 public:
  explicit CameraFrame(const pf_camera& c) : width_(c.width), height_(c.height) {
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
  return true;
}

}  // namespace pf
