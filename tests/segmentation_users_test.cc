// Components, the person test and stable ids on hand-made frames.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/segmentation_test_util.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using dp::testing_seg::SegmenterHarness;
using dp::testing_seg::count_pixels;
using dp::testing_seg::person_at;
using dp::testing_seg::truth_pixels;

namespace {

tools::Scene room() {
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 12.0f;
  s.camera.roll_deg = 3.0f;
  return s;
}

}  // namespace

TEST(SegmentationComponents, TwoPeopleAndFurnitureOnTheFloor) {
  tools::Scene s = room();
  s.cylinders.push_back(person_at(-0.8f, 3.0f, 1));
  s.cylinders.push_back(person_at(0.9f, 2.2f, 2));
  s.boxes.push_back({-0.2f, 0.4f, 0.0f, 0.75f, 3.6f, 4.2f, 0});   // table behind, between them
  s.cylinders.push_back({1.6f, 3.5f, 0.25f, 0.0f, 0.5f, 0});      // bin
  s.boxes.push_back({-2.0f, -1.5f, 0.0f, 0.45f, 2.0f, 2.5f, 0});  // stool
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  EXPECT_GE(h.result.component_count, 4);
  // Ids by size: the nearer person (truth 2) is larger and gets id 1.
  const UserInfo* near_user = h.user(1);
  const UserInfo* far_user = h.user(2);
  ASSERT_TRUE(near_user && far_user);
  for (uint8_t id = 1; id <= 2; ++id) {
    const uint8_t truth = id == 1 ? 2 : 1;
    SCOPED_TRACE(int(id));
    EXPECT_EQ(count_pixels(h.labels, f, id, 0), 0) << "background labelled as a user";
    EXPECT_EQ(count_pixels(h.labels, f, id, 3 - truth), 0) << "the other person labelled as this one";
    EXPECT_GE(count_pixels(h.labels, f, id, truth), int(0.97 * truth_pixels(f, truth)));
  }
  EXPECT_NEAR(near_user->centroid_m[2], 2.2 - 0.0, 0.35);
  EXPECT_NEAR(near_user->top_height_m, 1.7, 0.03);
  EXPECT_EQ(near_user->pixel_count, count_pixels(h.labels, f, 1, 2));
  EXPECT_EQ(h.result.user_pixels, near_user->pixel_count + far_user->pixel_count);
  // Bounding box matches the labelled pixels.
  int u0 = 9999, u1 = -1;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u)
      if (h.labels[size_t(v) * f.width + u] == 1) { u0 = std::min(u0, u); u1 = std::max(u1, u); }
  EXPECT_EQ(near_user->u_min, u0);
  EXPECT_EQ(near_user->u_max, u1);
}

TEST(SegmentationComponents, DepthJumpsSplitAndSmoothSurfacesJoin) {
  // Without a floor: two discs overlapping in the image, 40 cm apart in depth → two components;
  // a steep but smooth tilted plane stays one component.
  tools::SyntheticFrame f = tools::make_disc_frame(320, 240, 140, 120, 60, 2000);
  const tools::SyntheticFrame g = tools::make_disc_frame(320, 240, 200, 120, 60, 2400);
  for (size_t i = 0; i < f.depth_mm.size(); ++i)
    if (!f.depth_mm[i]) f.depth_mm[i] = g.depth_mm[i];
  SegmenterConfig cfg = default_segmenter_config(false);
  cfg.floor_enabled = false;
  cfg.min_person_height_m = 0.0f;  // discs are no people; this test is about components
  SegmenterHarness h(cfg);
  ASSERT_EQ(h.run(f.view()), Status::kOk);
  EXPECT_EQ(h.result.component_count, 2);
  ASSERT_EQ(h.result.user_count, 2);
  // Every disc pixel belongs to exactly the user of its depth.
  const uint8_t near_id = h.labels[120 * 320 + 100], far_id = h.labels[120 * 320 + 250];
  EXPECT_NE(near_id, 0);
  EXPECT_NE(far_id, 0);
  EXPECT_NE(near_id, far_id);
  for (size_t i = 0; i < f.depth_mm.size(); ++i) {
    const uint8_t want = f.depth_mm[i] == 2000 ? near_id : f.depth_mm[i] == 2400 ? far_id : 0;
    ASSERT_EQ(h.labels[i], want) << "pixel " << i;
  }
  // 6 mm per pixel along u at 2.5 m: well inside the join threshold → a single component.
  tools::SyntheticFrame plane = tools::make_plane_frame(160, 120, 2500.0f, 6.0f, 0.0f);
  SegmenterHarness p(cfg, 160, 120);
  ASSERT_EQ(p.run(plane.view()), Status::kOk);
  EXPECT_EQ(p.result.component_count, 1);
}

TEST(SegmentationComponents, TooSmallOrTooLowForAPersonIsDropped) {
  tools::Scene s = room();
  s.cylinders.push_back(person_at(0.0f, 2.5f, 1, 0.6f));           // a bin-sized "person": too low
  s.cylinders.push_back({1.0f, 3.0f, 0.01f, 0.0f, 1.8f, 0});        // a thin pole: too few pixels
  s.boxes.push_back({-2.5f, 0.6f, 0.0f, 1.6f, 4.0f, 4.3f, 0});      // a 3 m wide cupboard: too wide
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_EQ(h.result.user_count, 0);
  EXPECT_GE(h.result.component_count, 3);
  for (uint8_t l : h.labels) ASSERT_EQ(l, 0);
}

TEST(SegmentationUsers, IdsStayThroughAShortOcclusion) {
  SegmenterConfig cfg = default_segmenter_config(false);
  cfg.track_keep_frames = 8;
  SegmenterHarness h(cfg);
  // Person A walks right to left at 3 m, behind a wardrobe-sized occluder for several frames;
  // person B stands at 2 m. A keeps its id when it reappears.
  int id_a = 0, id_b = 0;
  bool hidden_seen = false;
  for (int frame = 0; frame < 24; ++frame) {
    tools::Scene s = room();
    const float ax = 1.2f - 0.1f * frame;
    s.cylinders.push_back(person_at(ax, 3.2f, 1));
    s.cylinders.push_back(person_at(-1.0f, 2.0f, 2));
    s.boxes.push_back({-0.35f, 0.35f, 0.0f, 2.0f, 2.4f, 2.5f, 0});  // occluder, 2 m tall, 70 cm wide
    const tools::RenderedScene f = tools::render_scene(s);
    ASSERT_EQ(h.run(f), Status::kOk);
    SCOPED_TRACE(::testing::Message() << "frame " << frame << " ax " << ax);
    // The occluder is wider than a person would look... but it is 2 m tall and 0.7 m wide: a
    // person-like box. It stands from frame 0 and is found as a user too; identify users by truth.
    int label_a = 0, label_b = 0;
    for (size_t i = 0; i < f.truth.size(); ++i) {
      if (f.truth[i] == 1 && h.labels[i]) label_a = h.labels[i];
      if (f.truth[i] == 2 && h.labels[i]) label_b = h.labels[i];
    }
    ASSERT_NE(label_b, 0);
    if (id_b == 0) id_b = label_b;
    EXPECT_EQ(label_b, id_b);
    const int visible_a = truth_pixels(f, 1);
    if (visible_a > 400) {
      ASSERT_NE(label_a, 0) << visible_a << " visible pixels of A";
      if (id_a == 0) id_a = label_a;
      EXPECT_EQ(label_a, id_a) << "A changed id";
    } else if (visible_a == 0) {
      hidden_seen = true;
    }
  }
  EXPECT_TRUE(hidden_seen) << "the scene never hid person A completely";
  EXPECT_NE(id_a, id_b);
}

TEST(SegmentationUsers, NewIdAfterTheKeepWindowAndLowestFreeIdReused) {
  SegmenterConfig cfg = default_segmenter_config(false);
  cfg.track_keep_frames = 2;
  SegmenterHarness h(cfg);
  tools::Scene two = room();
  two.cylinders.push_back(person_at(-0.8f, 2.5f, 1));
  two.cylinders.push_back(person_at(0.8f, 3.5f, 2));
  ASSERT_EQ(h.run(tools::render_scene(two)), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  EXPECT_EQ(h.result.users[0].id, 1);
  EXPECT_EQ(h.result.users[1].id, 2);
  EXPECT_EQ(h.result.users[0].frames_tracked, 1);
  tools::Scene one = room();
  one.cylinders.push_back(person_at(0.8f, 3.5f, 2));
  for (int i = 0; i < 3; ++i) {  // id 1 lost for 3 frames > keep (2): freed
    ASSERT_EQ(h.run(tools::render_scene(one)), Status::kOk);
    ASSERT_EQ(h.result.user_count, 1);
    EXPECT_EQ(h.result.users[0].id, 2);
    EXPECT_EQ(h.result.users[0].frames_tracked, 2 + i);
  }
  tools::Scene back = room();
  back.cylinders.push_back(person_at(0.8f, 3.5f, 2));
  back.cylinders.push_back(person_at(-0.7f, 2.0f, 3));  // someone else, elsewhere
  ASSERT_EQ(h.run(tools::render_scene(back)), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  EXPECT_EQ(h.result.users[0].id, 1);  // the lowest free id
  EXPECT_EQ(h.result.users[0].frames_tracked, 1);
  EXPECT_EQ(h.result.users[1].id, 2);
}

TEST(SegmentationUsers, MaxUsersCapsTheCount) {
  SegmenterConfig cfg = default_segmenter_config(false);
  cfg.max_users = 2;
  SegmenterHarness h(cfg);
  tools::Scene s = room();
  for (int i = 0; i < 4; ++i) s.cylinders.push_back(person_at(-1.5f + 1.0f * i, 3.0f + 0.2f * i, uint8_t(i + 1)));
  ASSERT_EQ(h.run(tools::render_scene(s)), Status::kOk);
  EXPECT_EQ(h.result.user_count, 2);
  EXPECT_TRUE(h.result.flags & kSegFlagUsersTruncated);
  for (uint8_t l : h.labels) ASSERT_LE(l, 2);
}

TEST(SegmentationUsers, BoundedOnAFrameFullOfClutter) {
  // Every pixel its own component (random depths far apart) and a grid of 192 small boxes: the
  // candidate list saturates at kMaxCandidates, the largest components are kept, nothing overflows.
  SegmenterConfig cfg = default_segmenter_config(false);
  cfg.min_component_pixels = 1;
  SegmenterHarness h(cfg, 640, 480);
  std::vector<uint16_t> noise(640 * 480);
  std::mt19937 rng(3);
  for (auto& z : noise) z = uint16_t(500 + 500 * (rng() % 11));
  const DepthFrame nf{noise.data(), 640, 480, 640, tools::kinect_intrinsics(640, 480), nullptr};
  ASSERT_EQ(h.run(nf), Status::kOk);
  EXPECT_TRUE(h.result.flags & kSegFlagCandidatesTruncated);
  EXPECT_GT(h.result.component_count, kMaxCandidates);
  EXPECT_LE(h.result.user_count, cfg.max_users);

  tools::Scene s = room();
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 12; ++j) {
      const float x = -3.0f + 0.38f * i, z = 1.5f + 0.3f * j;
      s.boxes.push_back({x, x + 0.12f, 0.0f, 0.3f + 0.02f * float((i * 7 + j) % 9), z, z + 0.1f, 0});
    }
  s.cylinders.push_back(person_at(0.1f, 2.0f, 1));
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness c(default_segmenter_config(false));
  ASSERT_EQ(c.run(f), Status::kOk);
  EXPECT_TRUE(c.result.flags & kSegFlagCandidatesTruncated);
  // The person is among the largest components and is still found.
  ASSERT_GE(c.result.user_count, 1);
  EXPECT_GT(count_pixels(c.labels, f, 1, 1), truth_pixels(f, 1) / 2);
}

TEST(SegmentationUsers, LabelsUseTheFrameStrideAndBadArgumentsAreRefused) {
  tools::Scene s = room();
  s.cylinders.push_back(person_at(0.0f, 2.5f, 1));
  const tools::RenderedScene f = tools::render_scene(s);
  const int stride = f.width + 13;
  std::vector<uint16_t> padded(size_t(stride) * f.height, 7);  // padding holds junk depth
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) padded[size_t(v) * stride + u] = f.depth_mm[size_t(v) * f.width + u];
  SegmenterHarness h(default_segmenter_config(false));
  std::vector<uint8_t> labels(size_t(stride) * f.height, 0xAB);
  h.result.labels = labels.data();
  const DepthFrame pf{padded.data(), f.width, f.height, stride, f.intrinsics, nullptr};
  ASSERT_EQ(h.segmenter.process(pf, &h.result), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  for (int v = 0; v < f.height; ++v) {
    for (int u = 0; u < f.width; ++u)
      ASSERT_EQ(labels[size_t(v) * stride + u] != 0, f.truth[size_t(v) * f.width + u] == 1 &&
                                                         labels[size_t(v) * stride + u] == 1);
    for (int u = f.width; u < stride; ++u) ASSERT_EQ(labels[size_t(v) * stride + u], 0xAB) << "padding written";
  }
  SegmentationResult r{};
  EXPECT_EQ(h.segmenter.process(pf, &r), Status::kBadArgument);  // no label buffer
  r.labels = labels.data();
  DepthFrame big = pf;
  big.width = 400;
  big.stride_px = 400;
  EXPECT_EQ(h.segmenter.process(big, &r), Status::kFrameTooLarge);
  Segmenter fresh;
  EXPECT_EQ(fresh.process(pf, &r), Status::kNotInitialized);
  SegmenterConfig bad = default_segmenter_config(false);
  bad.max_users = kMaxUsers + 1;
  EXPECT_EQ(h.segmenter.set_config(bad), Status::kBadConfig);
  std::vector<uint8_t> small(64 + 64);
  uint8_t* aligned = small.data() + (64 - reinterpret_cast<uintptr_t>(small.data()) % 64) % 64;
  EXPECT_EQ(fresh.init(default_segmenter_config(true), 320, 240, aligned, 64), Status::kArenaTooSmall);
  EXPECT_EQ(segmenter_required_bytes(0, 10), 0u);
}

TEST(SegmentationComponents, ABodyCutByADepthJumpIsOneUser) {
  // Upper body leaning 30 cm towards the camera over the legs: two components (the jump exceeds
  // the join threshold), the legs alone too low for a person; fragment merging makes one user.
  tools::Scene s = room();
  s.cylinders.push_back({0.0f, 3.0f, 0.15f, 0.0f, 0.9f, 1});   // legs
  s.cylinders.push_back({0.0f, 2.7f, 0.22f, 0.9f, 1.7f, 1});   // torso and head
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_EQ(h.result.component_count, 2);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, 1, 1), int(0.97 * truth_pixels(f, 1)));
  EXPECT_EQ(h.result.users[0].pixel_count, count_pixels(h.labels, f, 1, 1));
  EXPECT_NEAR(h.result.users[0].top_height_m, 1.7, 0.03);
  // Without merging the legs are dropped.
  SegmenterConfig cfg = default_segmenter_config(false);
  cfg.fragment_join_mm = 0.0f;
  SegmenterHarness n(cfg);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_EQ(n.result.user_count, 1);
  EXPECT_LT(count_pixels(n.labels, f, 1, 1), int(0.8 * truth_pixels(f, 1)));
}

TEST(SegmentationComponents, TwoPeopleSideBySideAreNotMerged) {
  tools::Scene s = room();
  s.cylinders.push_back(person_at(-0.25f, 3.0f, 1));
  s.cylinders.push_back(person_at(0.25f, 3.2f, 2));  // touching in the image, 20 cm behind
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_EQ(h.result.user_count, 2);
}

namespace {

// The id labelling most of truth `truth`'s pixels (0 when it is not in view or not labelled).
int id_of(const SegmenterHarness& h, const tools::RenderedScene& f, uint8_t truth) {
  int votes[16] = {};
  for (size_t i = 0; i < f.truth.size(); ++i)
    if (f.truth[i] == truth && h.labels[i] && h.labels[i] < 16) ++votes[h.labels[i]];
  int best = 0;
  for (int id = 1; id < 16; ++id)
    if (votes[id] > votes[best]) best = id;
  return best;
}

struct Person {
  float x, z, height;
  uint8_t truth;
};

// One frame of these people (cylinders on the floor of room()); their ids → *ids (by truth).
void show(SegmenterHarness& h, std::initializer_list<Person> people, int* ids, int* arrivals) {
  tools::Scene s = room();
  for (const Person& p : people) s.cylinders.push_back(person_at(p.x, p.z, p.truth, p.height));
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_EQ(h.run(f), Status::kOk);
  for (const Person& p : people) {
    ids[p.truth] = id_of(h, f, p.truth);
    const UserInfo* u = h.user(ids[p.truth]);
    ASSERT_TRUE(u) << "person " << int(p.truth) << " not found";
    arrivals[p.truth] = u->arrival;
  }
}

SegmenterConfig reid_config() {
  SegmenterConfig cfg = default_segmenter_config(false);
  cfg.track_keep_frames = 5;
  cfg.reid_window_frames = 60;
  return cfg;
}

}  // namespace

TEST(SegmentationUsers, AReturningPersonGetsItsIdBackByHeightANewcomerDoesNot) {
  SegmenterHarness h(reid_config());
  const Person tall{-0.8f, 3.0f, 1.85f, 1}, short_one{0.8f, 2.5f, 1.55f, 2};
  int ids[8] = {}, arrivals[8] = {};
  show(h, {tall, short_one}, ids, arrivals);
  EXPECT_EQ(arrivals[1], kUserNew);
  EXPECT_EQ(arrivals[2], kUserNew);
  const int tall_id = ids[1], short_id = ids[2];
  ASSERT_NE(tall_id, short_id);
  for (int i = 0; i < 12; ++i) {
    show(h, {tall, short_one}, ids, arrivals);
    EXPECT_EQ(arrivals[1], kUserContinued);
  }
  for (int i = 0; i < 10; ++i) show(h, {short_one}, ids, arrivals);  // the tall one is gone (> 5 frames)
  // A newcomer 25 cm shorter, where the tall one was: a new id, not the tall one's (reserved).
  const Person newcomer{-1.0f, 3.2f, 1.60f, 3};
  show(h, {short_one, newcomer}, ids, arrivals);
  EXPECT_EQ(arrivals[3], kUserNew);
  EXPECT_NE(ids[3], tall_id);
  EXPECT_NE(ids[3], short_id);
  for (int i = 0; i < 3; ++i) show(h, {short_one, newcomer}, ids, arrivals);
  // The tall one comes back elsewhere, 22 frames after last seen: its id again, marked returned.
  const Person back{0.1f, 3.6f, 1.85f, 1};
  show(h, {short_one, newcomer, back}, ids, arrivals);
  EXPECT_EQ(ids[1], tall_id);
  EXPECT_EQ(arrivals[1], kUserReturned);
  show(h, {short_one, newcomer, back}, ids, arrivals);
  EXPECT_EQ(ids[1], tall_id);
  EXPECT_EQ(arrivals[1], kUserContinued);
  EXPECT_EQ(ids[2], short_id);
}

TEST(SegmentationUsers, TwoSimilarGonePeopleAreNotGuessedAndTheWindowEnds) {
  SegmenterHarness h(reid_config());
  const Person a{-0.8f, 3.0f, 1.80f, 1}, b{0.8f, 3.0f, 1.82f, 2};
  int ids[8] = {}, arrivals[8] = {};
  for (int i = 0; i < 12; ++i) show(h, {a, b}, ids, arrivals);
  const int id_a = ids[1], id_b = ids[2];
  for (int i = 0; i < 8; ++i) {  // both gone
    tools::Scene s = room();
    ASSERT_EQ(h.run(tools::render_scene(s)), Status::kOk);
    EXPECT_EQ(h.result.user_count, 0);
  }
  // One of them comes back: both heights fit within 5 cm, so no guess: a new id, neither of theirs.
  show(h, {a}, ids, arrivals);
  EXPECT_EQ(arrivals[1], kUserNew);
  EXPECT_NE(ids[1], id_a);
  EXPECT_NE(ids[1], id_b);

  // Alone, one of them returning after the window (60 frames) is new too.
  SegmenterHarness late(reid_config());
  for (int i = 0; i < 12; ++i) show(late, {a}, ids, arrivals);
  for (int i = 0; i < 70; ++i) ASSERT_EQ(late.run(tools::render_scene(room())), Status::kOk);
  show(late, {a}, ids, arrivals);
  EXPECT_EQ(arrivals[1], kUserNew);
  // Within the window it is returned (same recipe, 40 frames away).
  SegmenterHarness soon(reid_config());
  for (int i = 0; i < 12; ++i) show(soon, {a}, ids, arrivals);
  const int first = ids[1];
  for (int i = 0; i < 40; ++i) ASSERT_EQ(soon.run(tools::render_scene(room())), Status::kOk);
  show(soon, {a}, ids, arrivals);
  EXPECT_EQ(arrivals[1], kUserReturned);
  EXPECT_EQ(ids[1], first);
}

// Height alone does not tell two people apart: a newcomer of the gone person's height but of a
// clearly smaller build (silhouette area beyond reid_area_ratio), where that person was, gets a
// new id; the person itself, back, gets its id again.
TEST(SegmentationUsers, ANewcomerOfTheSameHeightButAnotherBuildIsNotTakenForTheGonePerson) {
  SegmenterHarness h(reid_config());
  const Person gone{-0.8f, 3.0f, 1.70f, 1}, stays{0.8f, 2.5f, 1.40f, 2};
  int ids[8] = {}, arrivals[8] = {};
  for (int i = 0; i < 12; ++i) show(h, {gone, stays}, ids, arrivals);
  const int gone_id = ids[1], stays_id = ids[2];
  for (int i = 0; i < 10; ++i) show(h, {stays}, ids, arrivals);  // person 1 gone (> 5 frames)
  // 2 cm taller, 0.24 m wide instead of 0.4 m (area ratio 1.6), where person 1 stood: a new id.
  tools::Scene s = room();
  s.cylinders.push_back(person_at(stays.x, stays.z, stays.truth, stays.height));
  s.cylinders.push_back(tools::SceneCylinder{-0.8f, 3.1f, 0.12f, 0.0f, 1.72f, 3});
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_EQ(h.run(f), Status::kOk);
  const int newcomer_id = id_of(h, f, 3);
  const UserInfo* u = h.user(newcomer_id);
  ASSERT_TRUE(u);
  EXPECT_NEAR(u->top_height_m, 1.72f, 0.03f);  // within reid_height_tolerance_m of person 1's
  EXPECT_EQ(u->arrival, kUserNew);
  EXPECT_NE(newcomer_id, gone_id);
  EXPECT_NE(newcomer_id, stays_id);
  for (int i = 0; i < 8; ++i) ASSERT_EQ(h.run(tools::render_scene([&] {  // the newcomer leaves
                                           tools::Scene t = room();
                                           t.cylinders.push_back(person_at(stays.x, stays.z, stays.truth, stays.height));
                                           return t;
                                         }())), Status::kOk);
  // Person 1 itself comes back: its id again.
  show(h, {stays, gone}, ids, arrivals);
  EXPECT_EQ(ids[1], gone_id);
  EXPECT_EQ(arrivals[1], kUserReturned);
}

// A lost track's reach grows each frame it is lost; a piece of clutter within it must not continue
// the track (lost_min_height_ratio), else the person is never gone, no id is kept for it, and it
// comes back under a new one. A 1.1 m person stands 0.7 m from a 0.6 m box, vanishes for 10 frames
// (beyond track_keep_frames) and comes back where it was.
TEST(SegmentationUsers, ALostPersonsTrackDoesNotTakeTheBoxBesideIt) {
  const Person person{-0.5f, 3.0f, 1.1f, 1};
  const tools::SceneBox box{0.0f, 0.4f, 0.0f, 0.6f, 2.9f, 3.3f, 0};
  auto frame = [&](bool with_person) {
    tools::Scene s = room();
    if (with_person) s.cylinders.push_back(person_at(person.x, person.z, person.truth, person.height));
    s.boxes.push_back(box);
    return tools::render_scene(s);
  };
  // Runs the scene; returns the frames in which the box (the only thing in view) was labelled a user
  // while the person was away, and the person's id and arrival before and after.
  struct Outcome { int box_user_frames = 0, id_before = 0, id_back = 0, arrival_back = -1; };
  auto run = [&](float ratio) {
    SegmenterConfig cfg = reid_config();
    cfg.lost_min_height_ratio = ratio;
    SegmenterHarness h(cfg);
    Outcome o;
    for (int i = 0; i < 12; ++i) {
      const tools::RenderedScene f = frame(true);
      EXPECT_EQ(h.run(f), Status::kOk);
      EXPECT_EQ(h.result.user_count, 1) << "the box is no user while the person is in view";
      o.id_before = id_of(h, f, person.truth);
    }
    for (int i = 0; i < 10; ++i) {
      EXPECT_EQ(h.run(frame(false)), Status::kOk);
      o.box_user_frames += h.result.user_count > 0;
    }
    const tools::RenderedScene back = frame(true);
    EXPECT_EQ(h.run(back), Status::kOk);
    o.id_back = id_of(h, back, person.truth);
    if (const UserInfo* u = h.user(o.id_back)) o.arrival_back = u->arrival;
    return o;
  };
  // The scene does what it is for: with the test off, the lost track takes the box.
  const Outcome off = run(0.0f);
  EXPECT_GT(off.box_user_frames, 0);
  EXPECT_NE(off.arrival_back, kUserReturned);
  // With it (the default), the box is never a user, and the person gets its id back.
  const Outcome on = run(default_segmenter_config(false).lost_min_height_ratio);
  EXPECT_EQ(on.box_user_frames, 0);
  ASSERT_NE(on.id_before, 0);
  EXPECT_EQ(on.id_back, on.id_before);
  EXPECT_EQ(on.arrival_back, kUserReturned);
}
