#include "tools/app/overlay.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace dp::tools {

namespace {

// Bones between the project's joint names (tools/common/body_model.h). The joint set has no hips,
// so the torso sides run from the shoulders to the knees.
constexpr const char* kBones[][2] = {
    {"head", "neck"},         {"neck", "shoulder_l"},   {"neck", "shoulder_r"},   {"shoulder_l", "elbow_l"},
    {"elbow_l", "wrist_l"},   {"wrist_l", "hand_l"},    {"shoulder_r", "elbow_r"}, {"elbow_r", "wrist_r"},
    {"wrist_r", "hand_r"},    {"shoulder_l", "knee_l"}, {"shoulder_r", "knee_r"}, {"knee_l", "ankle_l"},
    {"ankle_l", "foot_l"},    {"knee_r", "ankle_r"},    {"ankle_r", "foot_r"},
};

int joint_index(const blob::ForestMeta& meta, const char* name) {
  for (int j = 0; j < meta.joint_count; ++j)
    if (std::strncmp(meta.joint_names[j], name, blob::kNameBytes) == 0) return j;
  return -1;
}

void draw_line(ImageRgb* image, float u0, float v0, float u1, float v1, const uint8_t rgb[3]) {
  const float length = std::max(std::fabs(u1 - u0), std::fabs(v1 - v0));
  const int steps = int(std::min(length, 8192.0f)) + 1;
  for (int i = 0; i <= steps; ++i) {
    const float t = float(i) / float(steps);
    image->set(int(std::lround(u0 + t * (u1 - u0))), int(std::lround(v0 + t * (v1 - v0))), rgb[0], rgb[1], rgb[2]);
  }
}

void draw_dot(ImageRgb* image, float u, float v, int radius, const uint8_t rgb[3]) {
  const int cu = int(std::lround(u)), cv = int(std::lround(v));
  for (int dv = -radius; dv <= radius; ++dv)
    for (int du = -radius; du <= radius; ++du)
      if (du * du + dv * dv <= radius * radius) image->set(cu + du, cv + dv, rgb[0], rgb[1], rgb[2]);
}

}  // namespace

void part_colour(int part, uint8_t rgb[3]) {
  // Golden-angle hues: neighbouring part ids get clearly different colours.
  const float hue = std::fmod(float(part) * 137.508f, 360.0f) / 60.0f;
  const float s = (part % 2) ? 0.65f : 0.95f, v = 0.95f;
  const int sector = int(hue) % 6;
  const float f = hue - std::floor(hue);
  const float p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  float r = 0, g = 0, b = 0;
  switch (sector) {
    case 0: r = v; g = t; b = p; break;
    case 1: r = q; g = v; b = p; break;
    case 2: r = p; g = v; b = t; break;
    case 3: r = p; g = q; b = v; break;
    case 4: r = t; g = p; b = v; break;
    default: r = v; g = p; b = q; break;
  }
  rgb[0] = uint8_t(r * 255.0f);
  rgb[1] = uint8_t(g * 255.0f);
  rgb[2] = uint8_t(b * 255.0f);
}

bool project(const CameraIntrinsics& k, float x, float y, float z, float* u, float* v) {
  if (!(z > 0.0f)) return false;
  *u = x * k.fx / z + k.cx;
  *v = -y * k.fy / z + k.cy;
  return std::isfinite(*u) && std::isfinite(*v);
}

void draw_overlay(const DepthFrame& frame, const Pipeline& pipeline, const FrameResult& result, ImageRgb* image) {
  draw_depth_grey(frame, pipeline.config(), image);
  draw_evaluated_pixels(pipeline, image);
  draw_skeleton(frame, *pipeline.blob().meta, result, image);
}

void draw_depth_grey(const DepthFrame& frame, const blob::RuntimeConfig& config, ImageRgb* image) {
  // Depth in grey: near = bright, far = dark, no reading = black.
  const int near = config.near_mm, far = std::max<int>(config.far_mm, near + 1);
  for (int v = 0; v < frame.height; ++v)
    for (int u = 0; u < frame.width; ++u) {
      const int z = frame.depth_mm[size_t(v) * frame.stride_px + u];
      uint8_t g = 0;
      if (z > 0) g = uint8_t(40 + 180 * (far - std::clamp(z, near, far)) / (far - near));
      uint8_t* p = &image->pixels[(size_t(v) * frame.width + u) * 3];
      p[0] = p[1] = p[2] = g;
    }
}

void draw_evaluated_pixels(const Pipeline& pipeline, ImageRgb* image) {
  const blob::LoadedBlob& b = pipeline.blob();
  const bool bpc = b.method() == blob::Method::kBpc && b.meta->part_count > 0;
  uint16_t distribution[blob::kMaxParts];
  const uint8_t ojr_tint[3] = {90, 170, 255};
  for (int32_t i = 0; i < pipeline.evaluated_pixel_count(); ++i) {
    const EvaluatedPixel& px = pipeline.evaluated_pixels()[i];
    uint8_t rgb[3] = {ojr_tint[0], ojr_tint[1], ojr_tint[2]};
    if (bpc) {
      pipeline.part_distribution(i, distribution);
      int best = 0;
      for (int c = 1; c < b.meta->part_count; ++c)
        if (distribution[c] > distribution[best]) best = c;
      part_colour(best, rgb);
    }
    image->set(px.u, px.v, rgb[0], rgb[1], rgb[2]);
  }
}

void draw_skeleton(const DepthFrame& frame, const blob::ForestMeta& meta, const FrameResult& result, ImageRgb* image) {
  const uint8_t bone[3] = {255, 255, 255}, joint[3] = {255, 40, 40};
  for (const auto& pair : kBones) {
    const int a = joint_index(meta, pair[0]), c = joint_index(meta, pair[1]);
    if (a < 0 || c < 0 || a >= result.joint_count || c >= result.joint_count) continue;
    if (!result.proposal_count[a] || !result.proposal_count[c]) continue;
    const JointProposal& pa = result.proposals[a][0];
    const JointProposal& pc = result.proposals[c][0];
    float u0, v0, u1, v1;
    if (project(frame.intrinsics, pa.x_m, pa.y_m, pa.z_m, &u0, &v0) &&
        project(frame.intrinsics, pc.x_m, pc.y_m, pc.z_m, &u1, &v1))
      draw_line(image, u0, v0, u1, v1, bone);
  }
  for (int j = 0; j < result.joint_count; ++j) {
    if (!result.proposal_count[j]) continue;
    const JointProposal& p = result.proposals[j][0];
    float u, v;
    if (project(frame.intrinsics, p.x_m, p.y_m, p.z_m, &u, &v)) draw_dot(image, u, v, 4, joint);
  }
}

}  // namespace dp::tools
