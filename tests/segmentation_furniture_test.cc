// The tall-furniture rule of the person test (furniture_smooth_min_share, furniture_smooth_step_m,
// furniture_pole_max_width_m, furniture_pole_min_share; docs/segmentation.md, "Tall furniture"):
// a door, a shelf and a coat stand as tall as people are no users with the rule on and users with
// it off (so each scene needs the rule), and a body whose width changes with height stays a user.
#include <gtest/gtest.h>

#include "tests/segmentation_test_util.h"

namespace dp {
namespace {

using testing_seg::SegmenterHarness;

tools::Scene room() {
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 10.0f;
  return s;
}

// Users the segmenter finds in `scene` with the default configuration for independent frames,
// the furniture rule on or off.
int users_in(const tools::Scene& scene, bool furniture_rule) {
  SegmenterHarness h(default_segmenter_config(false), 320, 240, furniture_rule);
  EXPECT_EQ(h.run(tools::render_scene(scene)), Status::kOk);
  return h.result.user_count;
}

// A standing body whose width along the floor changes from one 0.1 m height band to the next, as
// a body's does (shins, knees, thighs, hips, waist, chest, shoulders and arms, neck, head): parts
// 0.1 m tall, each differing from the one below by 3 cm or more, at floor point (x, z).
void add_body(tools::Scene* s, float x, float z, uint8_t truth) {
  // Per 0.1 m of height from the floor up: the half-width (m) of the part there.
  static const float kHalfWidth[] = {0.16f, 0.12f, 0.15f, 0.11f, 0.14f, 0.18f, 0.15f, 0.19f, 0.16f,
                                     0.20f, 0.17f, 0.22f, 0.19f, 0.25f, 0.21f, 0.06f, 0.10f, 0.08f};
  const int parts = int(sizeof kHalfWidth / sizeof kHalfWidth[0]);
  for (int i = 0; i < parts; ++i) {
    const float y0 = 0.1f * float(i), y1 = 0.1f * float(i + 1);
    s->boxes.push_back({x - kHalfWidth[i], x + kHalfWidth[i], y0, y1, z - 0.1f, z + 0.1f, truth});
  }
}

TEST(SegmentationFurniture, ABodyWhoseWidthChangesWithHeightIsAUser) {
  tools::Scene s = room();
  add_body(&s, 0.0f, 3.0f, 1);
  EXPECT_EQ(users_in(s, true), 1);
  EXPECT_EQ(users_in(s, false), 1);
}

TEST(SegmentationFurniture, ADoorIsNoUser) {
  tools::Scene s = room();
  s.boxes.push_back({-0.4f, 0.45f, 0.0f, 2.0f, 3.0f, 3.04f, 0});  // 0.85 m wide, 4 cm thick, 2 m tall
  EXPECT_EQ(users_in(s, false), 1) << "the door should pass the person test without the rule";
  EXPECT_EQ(users_in(s, true), 0);
}

TEST(SegmentationFurniture, AShelfSeenAtACornerIsNoUser) {
  tools::Scene s = room();
  s.camera.height_m = 1.9f;  // above its top: the top face is in view too
  s.boxes.push_back({-0.9f, -0.1f, 0.0f, 1.6f, 2.6f, 3.0f, 0});
  EXPECT_EQ(users_in(s, false), 1);
  EXPECT_EQ(users_in(s, true), 0);
}

TEST(SegmentationFurniture, ACoatStandIsNoUserByThePoleTestAlone) {
  tools::Scene s = room();
  s.cylinders.push_back({0.3f, 2.5f, 0.17f, 0.0f, 0.03f, 0});  // base disc
  s.cylinders.push_back({0.3f, 2.5f, 0.025f, 0.0f, 1.8f, 0});  // the pole
  s.cylinders.push_back({0.3f, 2.5f, 0.2f, 1.55f, 1.8f, 0});   // crown with coats
  SegmenterConfig pole_only = default_segmenter_config(false);
  pole_only.furniture_smooth_min_share = 0.0f;
  ASSERT_GT(pole_only.furniture_pole_max_width_m, 0.0f);
  SegmenterHarness on(pole_only, 320, 240, true);
  ASSERT_EQ(on.run(tools::render_scene(s)), Status::kOk);
  EXPECT_EQ(on.result.user_count, 0);
  EXPECT_EQ(users_in(s, false), 1) << "the coat stand should pass the person test without the rule";
  EXPECT_EQ(users_in(s, true), 0);
}

TEST(SegmentationFurniture, ABodyBesideADoorStaysAUserAndTheDoorDoesNot) {
  tools::Scene s = room();
  add_body(&s, -0.5f, 3.0f, 1);
  s.boxes.push_back({0.3f, 1.15f, 0.0f, 2.0f, 3.4f, 3.44f, 0});
  SegmenterHarness h(default_segmenter_config(false), 320, 240, true);
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  // The user is the body: most of its pixels carry the body's truth.
  const int id = h.result.users[0].id;
  EXPECT_GT(testing_seg::count_pixels(h.labels, f, uint8_t(id), 1), 9 * testing_seg::truth_pixels(f, 1) / 10);
  EXPECT_EQ(testing_seg::count_pixels(h.labels, f, uint8_t(id), 0), 0);
}

}  // namespace
}  // namespace dp

namespace dp {
namespace {

// Tracked users re-judged (furniture_track_frames, furniture_track_window, furniture_static_m):
// a door admitted while the shape rules were off stays a user until it has been furniture-shaped
// and static in furniture_track_frames frames, then is no user, and stays out even in frames where
// the new-user test would not catch it.
TEST(SegmentationFurniture, ATrackedStaticDoorIsDroppedAfterTheEvidenceFrames) {
  tools::Scene s = room();
  s.boxes.push_back({-0.4f, 0.45f, 0.0f, 2.0f, 3.0f, 3.04f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  const SegmenterConfig rule_on = default_segmenter_config(false);
  const SegmenterConfig shape_off = testing_seg::without_furniture_rule(rule_on);
  ASSERT_GT(rule_on.furniture_track_frames, 1);
  ASSERT_GT(shape_off.furniture_track_frames, 0) << "the tracked re-judgment has its own switch";
  SegmenterHarness h(shape_off, 320, 240, true);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1) << "the door should pass the person test with the shape rules off";
  const int id = h.result.users[0].id;
  ASSERT_EQ(h.segmenter.set_config(rule_on), Status::kOk);
  for (int frame = 1; frame < rule_on.furniture_track_frames; ++frame) {
    ASSERT_EQ(h.run(f), Status::kOk);
    ASSERT_EQ(h.result.user_count, 1) << "dropped after " << frame << " frames of evidence, before the window";
    EXPECT_EQ(h.result.users[0].id, id);
  }
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_EQ(h.result.user_count, 0) << "still a user after furniture_track_frames frames of evidence";
  // Remembered: with the shape rules off again (the new-user test would admit it), it stays out.
  ASSERT_EQ(h.segmenter.set_config(shape_off), Status::kOk);
  for (int frame = 0; frame < 10; ++frame) {
    ASSERT_EQ(h.run(f), Status::kOk);
    EXPECT_EQ(h.result.user_count, 0) << "the dropped door came back " << frame << " frames later";
  }
}

// Evidence needs stillness: the same door moving 0.15 m a frame along the floor stays a user.
TEST(SegmentationFurniture, ATrackedDoorThatMovesIsKept) {
  const SegmenterConfig rule_on = default_segmenter_config(false);
  ASSERT_GT(0.15f, rule_on.furniture_static_m);
  SegmenterHarness h(testing_seg::without_furniture_rule(rule_on), 320, 240, true);
  for (int frame = 0; frame < 2 * rule_on.furniture_track_frames; ++frame) {
    tools::Scene s = room();
    const float x = -0.9f + 0.15f * float(frame);
    s.boxes.push_back({x, x + 0.85f, 0.0f, 2.0f, 3.0f, 3.04f, 0});
    ASSERT_EQ(h.run(tools::render_scene(s)), Status::kOk);
    EXPECT_EQ(h.result.user_count, 1) << "frame " << frame;
    if (frame == 0) {
      ASSERT_EQ(h.segmenter.set_config(rule_on), Status::kOk);
    }
  }
}

// People stand still: a body standing still for a whole window and more (alone, and beside a door
// at its depth) keeps its user and id.
TEST(SegmentationFurniture, AStillBodyKeepsItsUserAloneAndBesideADoor) {
  const SegmenterConfig config = default_segmenter_config(false);
  for (const bool door : {false, true}) {
    tools::Scene s = room();
    add_body(&s, -0.5f, 3.0f, 1);
    if (door) s.boxes.push_back({0.3f, 1.15f, 0.0f, 2.0f, 3.0f, 3.04f, 0});
    const tools::RenderedScene f = tools::render_scene(s);
    SegmenterHarness h(config, 320, 240, true);
    for (int frame = 0; frame < 2 * config.furniture_track_window; ++frame) {
      ASSERT_EQ(h.run(f), Status::kOk);
      ASSERT_EQ(h.result.user_count, 1) << (door ? "beside a door" : "alone") << ", frame " << frame;
      EXPECT_EQ(h.result.users[0].id, 1);
      EXPECT_GT(testing_seg::count_pixels(h.labels, f, 1, 1), 9 * testing_seg::truth_pixels(f, 1) / 10);
    }
  }
}

}  // namespace
}  // namespace dp
