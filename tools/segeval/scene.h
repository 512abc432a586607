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

namespace dp::tools {

// A seeded family of scenes for regression checks of the segmenter (tests/segmentation_golden_*):
// seed → camera (height 0.5–2.3 m, pitch −5..35°, roll −8..8°, sometimes a back wall), 1–4 people
// built from parts (legs, torso, head, arms; standing, crouching, lying or bent over; some with an
// arm held out, some close enough to be cut by an image border), 2–7 boxes and bins 0.3–0.8 m tall.
// `frame` moves the people along straight lines (0.03–0.12 m per frame), so a sequence exercises
// tracking and the background model. Same seed and frame, same scene, on every platform (integer
// generator; no library random numbers).
Scene random_scene(uint32_t seed, int frame, int width = 320, int height = 240);
// Sensor-like defects, deterministic in (seed, frame): ±0.2 % depth jitter, 1 % of readings
// dropped and short horizontal dropout runs along depth edges.
void add_depth_noise(RenderedScene* scene, uint32_t seed, int frame);

}  // namespace dp::tools
