// depthpose synth --people / --clutter (added for segmentation): several labelled bodies and
// furniture; one-body frames without clutter are unchanged by the additions.
#include <gtest/gtest.h>

#include <memory>
#include <nlohmann/json.hpp>

#include "tools/common/body_model.h"
#include "tools/synth/synth.h"
#include "tests/synth_room_scene.h"

using namespace dp::synth;

namespace {

std::unique_ptr<Synthesizer> make(int people, int clutter) { return dp::test::make_room_synth(people, clutter); }

}  // namespace

TEST(SegmentationSynthSceneSharedData, PeopleAndClutterAreLabelledAndBodyZeroIsUnchanged) {
  auto one = make(1, 0);
  auto many = make(3, 12);
  for (uint64_t frame = 0; frame < 3; ++frame) {
    SCOPED_TRACE(frame);
    const SynthFrame a = one->render_frame(7, frame);
    const SynthFrame b = many->render_frame(7, frame);
    // Body 0 and the camera are drawn first from the frame's stream: same joints either way.
    ASSERT_EQ(b.people_joints.size(), 3u);
    ASSERT_EQ(a.people_joints.size(), 1u);
    for (int j = 0; j < dp::tools::kJointCount; ++j) {
      EXPECT_EQ(a.joints[j].x, b.joints[j].x);
      EXPECT_EQ(a.joints[j].z, b.joints[j].z);
      EXPECT_EQ(b.joints[j].x, b.people_joints[0][j].x);
    }
    const FrameParams p = many->sample_frame_params(7, frame);
    EXPECT_EQ(p.others.size(), 2u);
    EXPECT_GE(p.clutter.size(), 3u) << "placement failed for most clutter";
    for (const ClutterItem& c : p.clutter) EXPECT_LE(c.height, 0.8);
    // people image: a body id exactly where parts has a body label; ids 1..3.
    std::vector<int> count(4, 0);
    for (size_t i = 0; i < b.parts.pixels.size(); ++i) {
      const bool body = b.parts.pixels[i] != dp::tools::kNotBodyLabel;
      ASSERT_EQ(body, b.people.pixels[i] != 0) << "pixel " << i;
      ASSERT_LE(b.people.pixels[i], 3);
      count[b.people.pixels[i]]++;
    }
    EXPECT_GT(count[1] + count[2] + count[3], 0);
    // frames.jsonl extra: a list of people with their joints, and the clutter.
    const nlohmann::json extra = nlohmann::json::parse(b.extra_json);
    ASSERT_TRUE(extra.contains("people"));
    ASSERT_EQ(extra["people"].size(), 3u);
    EXPECT_EQ(extra["people"][1]["joints"].size(), size_t(dp::tools::kJointCount));
    EXPECT_EQ(extra["clutter"].size(), p.clutter.size());
    EXPECT_FALSE(nlohmann::json::parse(a.extra_json).contains("people"));
  }
  // Clutter is background: readings nearer than in the one-body frame that belong to no body.
  const SynthFrame c = many->render_frame(7, 0);
  const SynthFrame d = one->render_frame(7, 0);
  int nearer_background = 0;
  for (size_t i = 0; i < c.clean.depth.size(); ++i)
    nearer_background += c.parts.pixels[i] == dp::tools::kNotBodyLabel && c.clean.depth[i] > 0 &&
                         (d.clean.depth[i] == 0 || c.clean.depth[i] < d.clean.depth[i] - 0.05f);
  EXPECT_GT(nearer_background, 500);
  EXPECT_THROW(make(9, 0), std::exception);
}
