// dp::Segmenter's ownership contract: not copyable (two copies would share one arena, its tracks
// and background model), movable (the moved-from segmenter is left uninitialized).
#include <gtest/gtest.h>

#include <type_traits>
#include <utility>

#include "tests/segmentation_test_util.h"

static_assert(!std::is_copy_constructible_v<dp::Segmenter>, "Segmenter must not be copyable");
static_assert(!std::is_copy_assignable_v<dp::Segmenter>, "Segmenter must not be copy-assignable");
static_assert(std::is_nothrow_move_constructible_v<dp::Segmenter>, "Segmenter moves");
static_assert(std::is_nothrow_move_assignable_v<dp::Segmenter>, "Segmenter move-assigns");

TEST(SegmentationContract, AMovedSegmenterKeepsItsStateAndTheSourceIsUninitialized) {
  using dp::testing_seg::SegmenterHarness;
  using dp::testing_seg::person_at;
  dp::tools::Scene scene;
  scene.camera.height_m = 1.2f;
  scene.camera.pitch_deg = 10.0f;
  scene.cylinders.push_back(person_at(0.0f, 3.0f, 1));
  const dp::tools::RenderedScene frame = dp::tools::render_scene(scene);
  SegmenterHarness h(dp::default_segmenter_config(true));
  ASSERT_EQ(h.run(frame), dp::Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  const int id = h.result.users[0].id;

  dp::Segmenter moved(std::move(h.segmenter));
  dp::SegmentationResult r{};
  r.labels = h.labels.data();
  ASSERT_EQ(moved.process(frame.view(), &r), dp::Status::kOk);
  ASSERT_EQ(r.user_count, 1);
  EXPECT_EQ(r.users[0].id, id);
  EXPECT_EQ(r.users[0].frames_tracked, 2);  // the track came along
  EXPECT_EQ(h.segmenter.process(frame.view(), &r), dp::Status::kNotInitialized);

  dp::Segmenter assigned;
  assigned = std::move(moved);
  ASSERT_EQ(assigned.process(frame.view(), &r), dp::Status::kOk);
  EXPECT_EQ(r.users[0].frames_tracked, 3);
  EXPECT_EQ(moved.process(frame.view(), &r), dp::Status::kNotInitialized);
}
