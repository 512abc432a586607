// Per-user joints: the forest runs once over all users' pixels, aggregation is per user.
#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "tests/segmentation_test_util.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using dp::testing_seg::SegmenterHarness;
using dp::testing_seg::person_at;

namespace {

struct LoadedPipeline {
  std::vector<uint8_t> bytes;
  blob::LoadedBlob view;
  std::unique_ptr<uint8_t, decltype(&std::free)> arena{nullptr, &std::free};
  Pipeline pipeline;
  explicit LoadedPipeline(const blob::BlobContents& c, int w = 320, int h = 240) {
    bytes = blob::write_blob(c);
    EXPECT_EQ(blob::load_blob(bytes.data(), bytes.size(), &view), blob::BlobStatus::kOk);
    const size_t n = required_arena_bytes(view, w, h);
    arena.reset(static_cast<uint8_t*>(std::aligned_alloc(64, (n + 63) / 64 * 64)));
    EXPECT_EQ(pipeline.init(view, w, h, arena.get(), n), Status::kOk);
  }
};

void mean_point(const DepthFrame& f, const uint8_t* mask, uint8_t id, double out[3]) {
  double s[3] = {0, 0, 0};
  int n = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      if (mask[size_t(v) * f.stride_px + u] != id) continue;
      const double z = f.depth_mm[size_t(v) * f.stride_px + u] * 0.001;
      s[0] += (u - f.intrinsics.cx) * z / f.intrinsics.fx;
      s[1] += -(v - f.intrinsics.cy) * z / f.intrinsics.fy;
      s[2] += z;
      ++n;
    }
  for (int k = 0; k < 3; ++k) out[k] = s[k] / n;
}

}  // namespace

TEST(SegmentationPipeline, BpcProposalsPerUserFromOneForestPass) {
  LoadedPipeline L(tools::single_part_bpc(4, 1, 2, 40));
  tools::SyntheticFrame f = tools::make_disc_frame(320, 240, 90, 120, 7, 2000);
  const tools::SyntheticFrame g = tools::make_disc_frame(320, 240, 230, 100, 5, 3000);
  std::vector<uint8_t> mask(f.depth_mm.size(), 0);
  for (size_t i = 0; i < f.depth_mm.size(); ++i) {
    if (f.depth_mm[i]) mask[i] = 3;
    if (g.depth_mm[i]) { f.depth_mm[i] = g.depth_mm[i]; mask[i] = 7; }
  }
  DepthFrame frame = f.view();
  frame.foreground_mask = mask.data();
  FrameResult all;
  ASSERT_EQ(L.pipeline.process(frame, &all), Status::kOk);
  EXPECT_EQ(all.proposal_count[0], 2) << "both discs in the joint result";
  for (uint8_t id : {uint8_t(3), uint8_t(7)}) {
    FrameResult one;
    ASSERT_EQ(L.pipeline.process_user(frame, id, &one), Status::kOk);
    double c[3];
    mean_point(frame, mask.data(), id, c);
    int pixels = 0;
    for (uint8_t m : mask) pixels += m == id;
    EXPECT_EQ(one.evaluated_pixels, pixels);
    ASSERT_EQ(one.joint_count, 2);
    for (int j = 0; j < 2; ++j) {
      ASSERT_EQ(one.proposal_count[j], 1) << "user " << int(id) << " joint " << j;
      EXPECT_NEAR(one.proposals[j][0].x_m, c[0], 0.003);
      EXPECT_NEAR(one.proposals[j][0].y_m, c[1], 0.003);
      EXPECT_NEAR(one.proposals[j][0].z_m, c[2] + 0.040, 0.001);
      const double z2 = (id == 3 ? 2.0 : 3.0) * (id == 3 ? 2.0 : 3.0);
      EXPECT_NEAR(one.proposals[j][0].confidence, z2 * pixels, 0.01 * z2 * pixels);
    }
    EXPECT_GT(one.stage_cycles[kStageVotes], 0u);
  }
  FrameResult none;
  ASSERT_EQ(L.pipeline.process_user(frame, 5, &none), Status::kOk);
  EXPECT_EQ(none.evaluated_pixels, 0);
  EXPECT_TRUE(none.flags & kFlagNoForeground);
  EXPECT_EQ(none.proposal_count[0], 0);
  EXPECT_EQ(L.pipeline.process_user(frame, 0, &none), Status::kBadArgument);
  DepthFrame unmasked = frame;
  unmasked.foreground_mask = nullptr;
  EXPECT_EQ(L.pipeline.process_user(unmasked, 3, &none), Status::kBadArgument);
  // process() afterwards is unaffected by the per-user filter.
  FrameResult again;
  ASSERT_EQ(L.pipeline.process(frame, &again), Status::kOk);
  EXPECT_EQ(again.proposal_count[0], all.proposal_count[0]);
  EXPECT_FLOAT_EQ(again.proposals[0][0].confidence, all.proposals[0][0].confidence);
}

TEST(SegmentationPipeline, OjrPerUserWithSegmenterLabels) {
  LoadedPipeline L(tools::single_vote_ojr(3, 0, 300, 100));
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 10.0f;
  s.cylinders.push_back(person_at(-0.7f, 2.6f, 1));
  s.cylinders.push_back(person_at(0.8f, 3.4f, 2));
  s.boxes.push_back({-0.2f, 0.3f, 0.0f, 0.6f, 4.0f, 4.4f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  DepthFrame frame = f.view();
  frame.foreground_mask = h.labels.data();
  FrameResult all;
  ASSERT_EQ(L.pipeline.process(frame, &all), Status::kOk);
  EXPECT_EQ(all.foreground_pixels, h.result.user_pixels);
  // Each user's proposals equal those of a run where only that user is in the mask (up to the
  // top-N vote selection, which sees a different candidate set when votes are truncated).
  for (int i = 0; i < h.result.user_count; ++i) {
    const UserInfo& u = h.result.users[i];
    FrameResult one;
    ASSERT_EQ(L.pipeline.process(frame, &all), Status::kOk);
    ASSERT_EQ(L.pipeline.process_user(frame, uint8_t(u.id), &one), Status::kOk);
    EXPECT_EQ(one.evaluated_pixels, u.pixel_count);
    std::vector<uint8_t> only(h.labels.size());
    for (size_t k = 0; k < only.size(); ++k) only[k] = h.labels[k] == u.id;
    DepthFrame alone = f.view();
    alone.foreground_mask = only.data();
    FrameResult ref;
    ASSERT_EQ(L.pipeline.process(alone, &ref), Status::kOk);
    ASSERT_EQ(ref.evaluated_pixels, u.pixel_count);
    for (int j = 0; j < 3; ++j) {
      ASSERT_GE(one.proposal_count[j], 1);
      ASSERT_GE(ref.proposal_count[j], 1);
      EXPECT_NEAR(one.proposals[j][0].x_m, ref.proposals[j][0].x_m, 0.03);
      EXPECT_NEAR(one.proposals[j][0].y_m, ref.proposals[j][0].y_m, 0.03);
      EXPECT_NEAR(one.proposals[j][0].z_m, ref.proposals[j][0].z_m, 0.03);
      // And it lies on this user, not the other one: within the user's height and depth.
      EXPECT_NEAR(one.proposals[j][0].x_m, u.centroid_m[0], 0.25);
      EXPECT_NEAR(one.proposals[j][0].z_m, u.centroid_m[2] + 0.1, 0.25);
    }
  }
}
