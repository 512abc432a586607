// Hand-made depth scenes with exact ground truth, for the segmentation tests and
// `depthpose segeval --scene`: a floor seen by a camera of known height, pitch and roll, vertical
// cylinders (people or bins), axis-aligned boxes (furniture) and an optional back wall.
// World frame: origin on the floor below the camera, y up, the camera looks along +z before
// pitch (positive = looking down) and roll (positive = clockwise as seen by the camera).
// Depth is the exact camera z of the first surface hit, rounded to millimetres.
#pragma once
#include <cstdint>
#include <vector>

#include "runtime/depthpose.h"

namespace dp::tools {

struct SceneCamera {
  int width = 320, height = 240;
  CameraIntrinsics intrinsics{};   // kinect_intrinsics(width, height) when fx == 0
  float height_m = 1.0f, pitch_deg = 0.0f, roll_deg = 0.0f;
};

struct SceneBox {            // x0 ≤ x ≤ x1, y0 ≤ y ≤ y1, z0 ≤ z ≤ z1 (world, metres)
  float x0, x1, y0, y1, z0, z1;
  uint8_t truth;             // 0 = background, else the person id it belongs to
};

struct SceneCylinder {       // vertical, closed at the top
  float x, z, radius, y0, y1;
  uint8_t truth;
};

struct Scene {
  SceneCamera camera;
  bool floor = true;
  float wall_z = 0.0f;       // back wall z = wall_z (0 = none)
  std::vector<SceneBox> boxes;
  std::vector<SceneCylinder> cylinders;
};

struct RenderedScene {
  int width = 0, height = 0;
  CameraIntrinsics intrinsics{};
  std::vector<uint16_t> depth_mm;  // 0 = nothing hit (or beyond 65 m)
  std::vector<uint8_t> truth;      // per pixel: truth id of the surface hit, 0 = background
  DepthFrame view() const { return DepthFrame{depth_mm.data(), width, height, width, intrinsics, nullptr}; }
};

RenderedScene render_scene(const Scene& scene);

// The floor as seen by the camera: n·p + d = height above the floor of camera-frame point p.
void floor_plane_in_camera(const SceneCamera& camera, float normal[3], float* d);
// World point → camera frame (metres).
void world_to_camera(const SceneCamera& camera, const float world[3], float camera_point[3]);

}  // namespace dp::tools
