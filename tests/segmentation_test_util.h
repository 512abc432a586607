// Shared by tests/segmentation_*_test.cc: a Segmenter with its own arena and label buffer.
#pragma once
#include <cstdlib>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "runtime/segmentation/segmenter.h"
#include "tools/segeval/scene.h"

namespace dp::testing_seg {

// `config` with the tall-furniture rule off.
inline SegmenterConfig without_furniture_rule(SegmenterConfig config) {
  config.furniture_smooth_min_share = 0.0f;
  config.furniture_pole_max_width_m = 0.0f;
  return config;
}

struct SegmenterHarness {
  std::unique_ptr<uint8_t, decltype(&std::free)> arena{nullptr, &std::free};
  size_t arena_bytes = 0;
  Segmenter segmenter;
  std::vector<uint8_t> labels;
  SegmentationResult result{};

  // The scenes of tools/segeval/scene.h build people from cylinders and boxes: vertical prisms,
  // which the tall-furniture rule (furniture_smooth_min_share, furniture_pole_max_width_m) takes
  // for furniture by design. The other rules' tests run with it off (`furniture_rule` false);
  // the furniture rule's own tests turn it on.
  explicit SegmenterHarness(const SegmenterConfig& config, int max_w = 320, int max_h = 240,
                            bool furniture_rule = false) {
    SegmenterConfig c = config;
    if (!furniture_rule) c = without_furniture_rule(c);
    arena_bytes = segmenter_required_bytes(max_w, max_h);
    arena.reset(static_cast<uint8_t*>(std::aligned_alloc(64, (arena_bytes + 63) / 64 * 64)));
    EXPECT_EQ(segmenter.init(c, max_w, max_h, arena.get(), arena_bytes), Status::kOk);
    labels.assign(size_t(max_w) * max_h, 0xEE);
  }
  Status run(const DepthFrame& frame) {
    result.labels = labels.data();
    return segmenter.process(frame, &result);
  }
  Status run(const tools::RenderedScene& scene) { return run(scene.view()); }
  const UserInfo* user(int id) const {
    for (int i = 0; i < result.user_count; ++i)
      if (result.users[i].id == id) return &result.users[i];
    return nullptr;
  }
};

// Users a fresh segmenter with `config` finds in `scene` (the run must succeed).
inline int users_found(const SegmenterConfig& config, const tools::RenderedScene& scene) {
  SegmenterHarness h(config);
  EXPECT_EQ(h.run(scene), Status::kOk);
  return h.result.user_count;
}

// A standing person as a cylinder (radius 0.2 m, 1.7 m tall) at world (x, z).
inline tools::SceneCylinder person_at(float x, float z, uint8_t truth, float height = 1.7f) {
  return tools::SceneCylinder{x, z, 0.2f, 0.0f, height, truth};
}

// Pixels whose truth is `truth`.
inline int truth_pixels(const tools::RenderedScene& s, uint8_t truth) {
  int n = 0;
  for (uint8_t t : s.truth) n += t == truth;
  return n;
}

// Pixels labelled `label` whose truth is `truth`.
inline int count_pixels(const std::vector<uint8_t>& labels, const tools::RenderedScene& s, uint8_t label, uint8_t truth) {
  int n = 0;
  for (size_t i = 0; i < s.truth.size(); ++i) n += labels[i] == label && s.truth[i] == truth;
  return n;
}

}  // namespace dp::testing_seg
