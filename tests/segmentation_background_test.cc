// The static background model: learning, removal, revealed background, still people.
#include <gtest/gtest.h>

#include "tests/segmentation_test_util.h"

using namespace dp;
using dp::testing_seg::SegmenterHarness;
using dp::testing_seg::count_pixels;
using dp::testing_seg::person_at;
using dp::testing_seg::truth_pixels;

namespace {

// A room without a visible floor plane fit (floor disabled) so that only the model removes things:
// back wall, a cupboard and a low table.
tools::Scene static_room() {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 8.0f;
  s.wall_z = 4.5f;
  s.boxes.push_back({-2.1f, -0.1f, 0.0f, 1.9f, 3.6f, 4.2f, 0});  // wardrobe, 2 m wide
  s.boxes.push_back({0.6f, 1.4f, 0.0f, 0.7f, 2.8f, 3.4f, 0});    // table
  return s;
}

SegmenterConfig model_only() {
  SegmenterConfig c = default_segmenter_config(true);
  c.floor_enabled = false;
  c.background_learn_frames = 5;
  return c;
}

}  // namespace

TEST(SegmentationBackground, LearnedSceneIsRemovedAndAPersonWalkingInIsFound) {
  SegmenterHarness h(model_only());
  const tools::RenderedScene empty = tools::render_scene(static_room());
  ASSERT_EQ(h.run(empty), Status::kOk);
  EXPECT_TRUE(h.result.flags & kSegFlagBackgroundLearning);
  EXPECT_GT(h.result.candidate_pixels, 0) << "frame 0: nothing learned yet";
  for (int i = 1; i < 5; ++i) {
    ASSERT_EQ(h.run(empty), Status::kOk);
    EXPECT_EQ(h.result.candidate_pixels, 0) << "frame " << i;
  }
  ASSERT_EQ(h.run(empty), Status::kOk);
  EXPECT_FALSE(h.result.flags & kSegFlagBackgroundLearning);
  // A person walks in front of the cupboard: exactly the person's pixels are foreground.
  tools::Scene s = static_room();
  s.cylinders.push_back(person_at(-1.0f, 2.8f, 1));
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  // Only the soles, within the model's tolerance of the floor behind them, are lost.
  EXPECT_EQ(h.result.candidate_pixels, count_pixels(h.labels, f, 1, 1));
  EXPECT_GE(count_pixels(h.labels, f, 1, 1), truth_pixels(f, 1) * 98 / 100);
}

TEST(SegmentationBackground, WithoutTheModelTheRoomIsCandidatePixels) {
  SegmenterConfig c = model_only();
  c.background_enabled = false;
  SegmenterHarness h(c);
  const tools::RenderedScene empty = tools::render_scene(static_room());
  for (int i = 0; i < 3; ++i) ASSERT_EQ(h.run(empty), Status::kOk);
  EXPECT_GT(h.result.candidate_pixels, empty.width * empty.height / 2);
  EXPECT_FALSE(h.result.flags & kSegFlagBackgroundLearning);
}

TEST(SegmentationBackground, PersonStillFromTheFirstFrameStaysAUser) {
  // Documented behaviour: pixels labelled as a user never enter the model, so someone standing
  // still from frame 0 is not learned away. (The floor fit separates them from the floor in
  // frame 0, before anything is learned.)
  SegmenterConfig c = model_only();
  c.floor_enabled = true;
  SegmenterHarness h(c);
  tools::Scene s = static_room();
  s.cylinders.push_back(person_at(0.3f, 2.5f, 1));
  const tools::RenderedScene f = tools::render_scene(s);
  for (int i = 0; i < 60; ++i) {
    ASSERT_EQ(h.run(f), Status::kOk);
    ASSERT_EQ(h.result.user_count, 1) << "frame " << i;
    EXPECT_EQ(h.result.users[0].id, 1);
    ASSERT_GE(count_pixels(h.labels, f, 1, 1), truth_pixels(f, 1) * 95 / 100) << "frame " << i;
  }
  // When they walk away, the wall behind them was never learned; it becomes background at once
  // (unknown pixels are learned from the first non-user reading), and the person is found again.
  tools::Scene moved = static_room();
  moved.cylinders.push_back(person_at(-0.1f, 2.2f, 1));
  const tools::RenderedScene g = tools::render_scene(moved);
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(h.run(g), Status::kOk);
    ASSERT_EQ(h.result.user_count, 1);
    EXPECT_EQ(h.result.users[0].id, 1);
    EXPECT_EQ(count_pixels(h.labels, g, 1, 0), 0) << "revealed wall labelled as the user";
    EXPECT_GE(count_pixels(h.labels, g, 1, 1), truth_pixels(g, 1) * 95 / 100);
  }
}

TEST(SegmentationBackground, RemovedObjectIsRevealedAfterRevealFrames) {
  SegmenterConfig c = model_only();
  c.background_reveal_frames = 3;
  SegmenterHarness h(c);
  const tools::RenderedScene with_table = tools::render_scene(static_room());
  for (int i = 0; i < 8; ++i) ASSERT_EQ(h.run(with_table), Status::kOk);
  tools::Scene s = static_room();
  s.boxes.pop_back();  // the table is carried away: the floor/wall behind it is farther
  const tools::RenderedScene without = tools::render_scene(s);
  int revealed = 0;
  for (size_t i = 0; i < without.depth_mm.size(); ++i) revealed += without.depth_mm[i] != with_table.depth_mm[i];
  ASSERT_GT(revealed, 1000);
  // Farther than the model: not "nearer than the background", so not a candidate even before
  // the model catches up; after reveal_frames the model holds the new depth.
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(h.run(without), Status::kOk);
    EXPECT_EQ(h.result.candidate_pixels, 0);
  }
  // Put the table back: nearer than the revealed model → candidate pixels again (not absorbed
  // by default); the table is no person, so no user.
  ASSERT_EQ(h.run(with_table), Status::kOk);
  EXPECT_GE(h.result.candidate_pixels, revealed * 9 / 10);
  EXPECT_EQ(h.result.user_count, 0);
}

TEST(SegmentationBackground, AbsorbFramesLearnsAPlacedObject) {
  SegmenterConfig c = model_only();
  c.background_absorb_frames = 4;
  SegmenterHarness h(c);
  tools::Scene s = static_room();
  s.boxes.pop_back();
  for (int i = 0; i < 8; ++i) ASSERT_EQ(h.run(tools::render_scene(s)), Status::kOk);
  const tools::RenderedScene with_table = tools::render_scene(static_room());
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(h.run(with_table), Status::kOk);
    EXPECT_GT(h.result.candidate_pixels, 0) << "frame " << i;
  }
  ASSERT_EQ(h.run(with_table), Status::kOk);
  EXPECT_EQ(h.result.candidate_pixels, 0);
}

TEST(SegmentationBackground, ResetForgetsTheModelAndSizeChangesRestartIt) {
  SegmenterHarness h(model_only());
  const tools::RenderedScene empty = tools::render_scene(static_room());
  for (int i = 0; i < 3; ++i) ASSERT_EQ(h.run(empty), Status::kOk);
  ASSERT_EQ(h.result.candidate_pixels, 0);
  h.segmenter.reset();
  ASSERT_EQ(h.run(empty), Status::kOk);
  EXPECT_GT(h.result.candidate_pixels, 0);
  EXPECT_TRUE(h.result.flags & kSegFlagBackgroundLearning);
  tools::Scene small = static_room();
  small.camera.width = 160;
  small.camera.height = 120;
  ASSERT_EQ(h.run(tools::render_scene(small)), Status::kOk);
  EXPECT_GT(h.result.candidate_pixels, 0) << "a new frame size starts a new model";
}

TEST(SegmentationBackground, LoosePiecesBesideAUserAreNotLearned) {
  // While the model learns, a small thing just beside a person (a hand cut off by a depth jump,
  // here a 5 cm post, too small for a person) is not learned: when the person then steps
  // onto that spot, where their front is at the post's depth, none of their body there is taken
  // for background. (The soles, continuing the floor, may go.)
  SegmenterConfig c = model_only();
  c.floor_enabled = true;
  SegmenterHarness h(c);
  tools::Scene learning = static_room();
  learning.cylinders.push_back(person_at(0.0f, 2.5f, 1));
  learning.cylinders.push_back({0.235f, 2.33f, 0.025f, 1.0f, 1.5f, 0});  // 1 cm beside them
  const tools::RenderedScene f = tools::render_scene(learning);
  for (int i = 0; i < 6; ++i) {
    ASSERT_EQ(h.run(f), Status::kOk);
    ASSERT_EQ(h.result.user_count, 1) << "frame " << i;
  }
  ASSERT_FALSE(h.result.flags & kSegFlagBackgroundLearning);
  tools::Scene stepped = static_room();
  stepped.cylinders.push_back(person_at(0.2f, 2.5f, 1));
  const tools::RenderedScene g = tools::render_scene(stepped);
  ASSERT_EQ(h.run(g), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, g, 1, 1), truth_pixels(g, 1) * 95 / 100);
}

TEST(SegmentationBackground, UnseenPixelsAreNotJudgedAcrossAGap) {
  // No floor, no wall: beyond the furniture there is no reading. A person standing still from
  // frame 0 is never learned; beside them, across a gap without readings, a sideboard at their
  // own depth is. Their unseen pixels must not be judged by the sideboard (they would lose every
  // row the sideboard spans), while a chain of readings from learned pixels would judge them.
  SegmenterConfig c = model_only();
  SegmenterHarness h(c);
  tools::Scene s;
  s.floor = false;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 8.0f;
  s.boxes.push_back({-1.6f, -0.4f, 0.0f, 0.8f, 2.4f, 2.8f, 0});  // sideboard (too low for a person), front at the person's depth
  s.cylinders.push_back(person_at(0.2f, 2.5f, 1));
  const tools::RenderedScene f = tools::render_scene(s);
  for (int i = 0; i < 10; ++i) {
    ASSERT_EQ(h.run(f), Status::kOk);
    ASSERT_EQ(h.result.user_count, 1) << "frame " << i;
    ASSERT_GE(count_pixels(h.labels, f, 1, 1), truth_pixels(f, 1) * 99 / 100) << "frame " << i;
  }
}
