// People cut by the top image border, bodies cut in pieces by depth jumps or by someone in front,
// and the floor margin at the soles (docs/segmentation.md, "Users").
#include <gtest/gtest.h>

#include <cmath>

#include "tests/segmentation_test_util.h"

using namespace dp;
using dp::testing_seg::SegmenterHarness;
using dp::testing_seg::count_pixels;
using dp::testing_seg::person_at;
using dp::testing_seg::truth_pixels;
using dp::testing_seg::users_found;

namespace {

// Labelled pixels whose truth is `truth`, whatever the label.
int labelled_truth(const std::vector<uint8_t>& labels, const tools::RenderedScene& f, uint8_t truth) {
  int n = 0;
  for (size_t i = 0; i < f.truth.size(); ++i) n += labels[i] != 0 && f.truth[i] == truth;
  return n;
}

// A low camera looking down at someone close: only the legs and the hips are in view.
tools::Scene low_camera() {
  tools::Scene s;
  s.camera.height_m = 0.8f;
  s.camera.pitch_deg = 25.0f;
  s.camera.roll_deg = 2.0f;
  return s;
}

// Legs apart (A-stance) and the hips; the torso is above the image.
void add_legs(tools::Scene* s, float x, float z, uint8_t truth) {
  s->cylinders.push_back({x - 0.22f, z, 0.07f, 0.0f, 0.7f, truth});
  s->cylinders.push_back({x + 0.22f, z, 0.07f, 0.0f, 0.7f, truth});
  s->boxes.push_back({x - 0.29f, x + 0.29f, 0.62f, 1.0f, z - 0.1f, z + 0.12f, truth});
  s->cylinders.push_back({x, z, 0.2f, 1.0f, 1.7f, truth});
}

// Whether some pixel of `truth` lies in the top image row, and the fill of its image box.
void truth_box(const tools::RenderedScene& f, uint8_t truth, bool* top_row, float* fill) {
  int u0 = f.width, u1 = -1, v0 = f.height, v1 = -1, n = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u)
      if (f.truth[size_t(v) * f.width + u] == truth) {
        u0 = std::min(u0, u); u1 = std::max(u1, u); v0 = std::min(v0, v); v1 = std::max(v1, v);
        ++n;
      }
  *top_row = v0 == 0;
  *fill = n ? float(n) / float((u1 - u0 + 1) * (v1 - v0 + 1)) : 0.0f;
}

}  // namespace

TEST(SegmentationCut, LegsCutByTheTopBorderAreAUserAndABoxCutThereIsNot) {
  tools::Scene s = low_camera();
  add_legs(&s, -0.45f, 1.4f, 1);
  s.boxes.push_back({0.25f, 0.85f, 0.0f, 0.78f, 1.3f, 1.7f, 0});  // a cupboard, as tall as furniture gets
  const tools::RenderedScene f = tools::render_scene(s);
  bool legs_top = false, box_top = false;
  float legs_fill = 0.0f, box_fill = 0.0f;
  truth_box(f, 1, &legs_top, &legs_fill);
  // The box rendered alone with a truth id of its own, to measure its silhouette.
  {
    tools::Scene only_box = low_camera();
    only_box.floor = false;
    only_box.boxes.push_back({0.25f, 0.85f, 0.0f, 0.78f, 1.3f, 1.7f, 7});
    truth_box(tools::render_scene(only_box), 7, &box_top, &box_fill);
  }
  ASSERT_TRUE(legs_top) << "the scene should cut the legs at the top border";
  ASSERT_TRUE(box_top) << "the scene should cut the box at the top border";
  ASSERT_LT(legs_fill, 0.6f);
  ASSERT_GT(box_fill, 0.6f);

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_LT(h.result.users[0].top_height_m, 0.85f) << "the height test alone would refuse them";
  EXPECT_GE(count_pixels(h.labels, f, 1, 1), int(0.9 * truth_pixels(f, 1)));
  EXPECT_EQ(count_pixels(h.labels, f, 1, 0), 0) << "the box joined the legs";

  // Without the relaxation the legs are dropped like the box.
  SegmenterConfig off = default_segmenter_config(false);
  off.cut_max_fill = 0.0f;
  EXPECT_EQ(users_found(off, f), 0);
}

TEST(SegmentationCut, ACutComponentMustStandOnTheFloor) {
  // Legs lifted 0.35 m (standing on something out of the floor's reach, or a fragment
  // hanging in the air) are not a person: the lowest point is above cut_floor_contact_m.
  tools::Scene s = low_camera();
  s.cylinders.push_back({-0.75f, 1.4f, 0.07f, 0.35f, 0.7f, 1});
  s.cylinders.push_back({-0.15f, 1.4f, 0.07f, 0.35f, 0.7f, 1});
  s.boxes.push_back({-0.82f, -0.08f, 0.66f, 1.0f, 1.3f, 1.52f, 1});
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  ASSERT_TRUE(top);
  ASSERT_LT(fill, 0.6f);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_EQ(h.result.user_count, 0);
  EXPECT_GT(h.result.component_count, 0) << h.result.candidate_pixels << " candidate pixels";
  SegmenterConfig low = default_segmenter_config(false);
  low.cut_floor_contact_m = 0.5f;
  EXPECT_EQ(users_found(low, f), 1);
}

TEST(SegmentationCut, APersonCutInTwoBySomeoneInFrontIsOneUser) {
  // A thin person (truth 2) close to the camera hides the middle of a person (truth 1) farther
  // away: two pieces that do not touch and each pass the person test on their own.
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 12.0f;
  s.cylinders.push_back(person_at(0.0f, 3.5f, 1));
  s.cylinders.push_back({0.0f, 2.0f, 0.06f, 0.0f, 1.8f, 2});
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_EQ(h.result.user_count, 2);
  uint8_t far_id = 0;
  for (size_t i = 0; i < f.truth.size(); ++i)
    if (f.truth[i] == 1 && h.labels[i]) far_id = h.labels[i];
  ASSERT_NE(far_id, 0);
  EXPECT_GE(count_pixels(h.labels, f, far_id, 1), int(0.97 * truth_pixels(f, 1)));
  EXPECT_EQ(count_pixels(h.labels, f, far_id, 2), 0) << "the person in front joined";
  // Without pair merging the far person is two users.
  SegmenterConfig off = default_segmenter_config(false);
  off.fragment_pair_radius_m = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  EXPECT_EQ(n.result.user_count, 3);
}

TEST(SegmentationCut, AnArmInFrontOfTheBodyIsNotAUserOfItsOwn) {
  // A forearm held 30 cm in front of the body beside the torso: a depth jump makes it its own
  // component, large and tall enough to pass, touching the body but not stacked on it.
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 12.0f;
  s.cylinders.push_back(person_at(0.0f, 3.0f, 1));
  s.cylinders.push_back({0.27f, 2.72f, 0.07f, 0.5f, 1.45f, 1});
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_GE(h.result.component_count, 2);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, h.result.users[0].id, 1), int(0.97 * truth_pixels(f, 1)));
  SegmenterConfig off = default_segmenter_config(false);
  off.fragment_pair_radius_m = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  EXPECT_EQ(n.result.user_count, 2);
}

TEST(SegmentationCut, TheFloorMarginKeepsTheSoles) {
  // A person at 2.5 m: pixels 2..4 cm above the floor are body, not floor (margin 10 mm +
  // 1 mm/m² · z²; 25 mm + 2 mm/m² · z² removes them).
  tools::Scene s;
  s.camera.height_m = 1.0f;
  s.camera.pitch_deg = 15.0f;
  s.cylinders.push_back(person_at(0.0f, 2.5f, 1));
  const tools::RenderedScene f = tools::render_scene(s);
  float n[3], d;
  tools::floor_plane_in_camera(s.camera, n, &d);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  int low = 0, kept = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const size_t i = size_t(v) * f.width + u;
      if (f.truth[i] != 1 || !f.depth_mm[i]) continue;
      const float z = f.depth_mm[i] * 0.001f;
      const float x = (u - f.intrinsics.cx) * z / f.intrinsics.fx, y = -(v - f.intrinsics.cy) * z / f.intrinsics.fy;
      const float up = n[0] * x + n[1] * y + n[2] * z + d;
      if (up < 0.02f || up > 0.04f) continue;
      ++low;
      kept += h.labels[i] != 0;
    }
  ASSERT_GT(low, 10);
  EXPECT_GE(kept, int(0.9 * low));
  SegmenterConfig old = default_segmenter_config(false);
  old.floor_margin_mm = 25.0f;
  old.floor_margin_per_m2_mm = 2.0f;
  SegmenterHarness o(old);
  ASSERT_EQ(o.run(f), Status::kOk);
  EXPECT_LT(labelled_truth(o.labels, f, 1), labelled_truth(h.labels, f, 1));
}

TEST(SegmentationCut, ABoxCutByTheTopBorderAndHiddenInPartsIsNotAUser) {
  // A stool in front of the box hides the middle of its lower part: what shows (an upside-down
  // U) fills less than cut_max_fill of its image box, but what the stool hides counts as filled,
  // so the box stays out.
  tools::Scene s = low_camera();
  s.boxes.push_back({0.1f, 0.9f, 0.0f, 0.78f, 1.3f, 1.7f, 7});
  s.boxes.push_back({0.2f, 0.8f, 0.0f, 0.5f, 0.95f, 1.1f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 7, &top, &fill);
  ASSERT_TRUE(top);
  ASSERT_LT(fill, 0.6f) << "the poles should break the box's silhouette";
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(labelled_truth(h.labels, f, 7), 0) << "the box is (part of) a user";
}

TEST(SegmentationCut, AHeadAboveTheBottomBorderIsAUser) {
  // A high camera and someone close: only the head is above the bottom border. It is high above
  // the floor (which is in view farther away) but smaller than the person area.
  tools::Scene s;
  s.camera.height_m = 2.0f;
  s.camera.pitch_deg = 5.0f;
  s.cylinders.push_back({0.0f, 0.9f, 0.2f, 0.0f, 1.45f, 1});   // torso, below the image
  s.cylinders.push_back({0.0f, 0.9f, 0.1f, 1.45f, 1.7f, 1});   // head
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_EQ(h.result.users[0].v_max, f.height - 1);
  EXPECT_GE(count_pixels(h.labels, f, 1, 1), int(0.97 * truth_pixels(f, 1)));
  SegmenterConfig off = default_segmenter_config(false);
  off.cut_bottom_area_fraction = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  EXPECT_EQ(n.result.user_count, 0) << "the head alone should be smaller than the person area";
}

TEST(SegmentationCut, AHandReachingOverABoxDoesNotMakeItAPerson) {
  // A forearm (truth 1) held 25 cm in front of a box's upper edge and above it: a component of
  // its own, touching the box within fragment_join_mm. Together they would pass the person test
  // (the box's area, the forearm's height), but the forearm is a tiny share of the union.
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 12.0f;
  s.boxes.push_back({-0.5f, 0.5f, 0.0f, 0.6f, 2.2f, 2.6f, 0});
  s.boxes.push_back({-0.02f, 0.02f, 0.45f, 0.95f, 1.93f, 1.97f, 1});
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_GE(h.result.component_count, 2);
  EXPECT_EQ(h.result.user_count, 0);
  SegmenterConfig any = default_segmenter_config(false);
  any.fragment_min_share = 0.0f;
  any.box_reject_min_share = 0.0f;  // the box reject's lid test refuses the union too
  SegmenterHarness a(any);
  ASSERT_EQ(a.run(f), Status::kOk);
  EXPECT_EQ(a.result.user_count, 1) << "the scene should offer the box and the forearm as one person";
}

TEST(SegmentationCut, LegsApartCutByTheTopBorderAreAUserByTheirHull) {
  // Legs in an A-stance (slanted, built of 5 cm slices) with thick thighs fill more than
  // cut_max_fill of their image box, like a box; the gap between them still leaves their row-wise
  // convex hull unfilled (below cut_max_solidity), where a box cut by the same border fills its
  // hull.
  tools::Scene s = low_camera();
  const float x = -0.35f, z = 1.4f;
  for (int k = 0; k < 14; ++k) {
    const float y0 = 0.05f * float(k), spread = 0.26f - 0.2f * float(k) / 13.0f, half = 0.075f + 0.03f * float(k) / 13.0f;
    for (float side : {-1.0f, 1.0f})
      s.boxes.push_back({x + side * spread - half, x + side * spread + half, y0, y0 + 0.05f, z - 0.07f, z + 0.07f, 1});
  }
  s.boxes.push_back({x - 0.17f, x + 0.17f, 0.62f, 1.0f, z - 0.1f, z + 0.12f, 1});
  s.boxes.push_back({0.25f, 0.85f, 0.0f, 0.78f, 1.3f, 1.7f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  bool legs_top = false;
  float legs_fill = 0.0f;
  truth_box(f, 1, &legs_top, &legs_fill);
  ASSERT_TRUE(legs_top) << "the scene should cut the legs at the top border";
  ASSERT_GT(legs_fill, 0.6f) << "the legs should fill their box like furniture";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_LT(h.result.users[0].top_height_m, 0.85f) << "the height test alone would refuse them";
  EXPECT_GE(count_pixels(h.labels, f, 1, 1), int(0.9 * truth_pixels(f, 1)));
  EXPECT_EQ(count_pixels(h.labels, f, 1, 0), 0) << "the box is (part of) the user";

  // Without the hull test and the gap rule (cut_gap_min_share: the floor shows
  // between the legs in their lower rows) they are dropped like the box.
  SegmenterConfig off = default_segmenter_config(false);
  off.cut_max_solidity = 0.0f;
  off.cut_gap_min_share = 0.0f;
  EXPECT_EQ(users_found(off, f), 0);
  // The gap rule alone takes them too.
  SegmenterConfig gap_only = default_segmenter_config(false);
  gap_only.cut_max_solidity = 0.0f;
  EXPECT_EQ(users_found(gap_only, f), 1);
}

namespace {
// Body surface in view of `truth` (m²): Σ z²/(fx·fy) over its pixels.
float visible_area(const tools::RenderedScene& f, uint8_t truth) {
  double a = 0.0;
  for (size_t i = 0; i < f.truth.size(); ++i)
    if (f.truth[i] == truth && f.depth_mm[i] != 0) {
      const double z = f.depth_mm[i] * 0.001;
      a += z * z / (double(f.intrinsics.fx) * f.intrinsics.fy);
    }
  return float(a);
}
}  // namespace

TEST(SegmentationCut, SomeoneMostlyHiddenBehindSomeoneElseIsAUser) {
  // Person 2 stands behind person 1 and shows a strip beside them: less than the person area, but
  // next to something much nearer and as high as a person. A box behind person 1 shows the same
  // way but is as low as furniture, and stays out.
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 5.0f;
  s.cylinders.push_back(person_at(0.0f, 2.0f, 1));
  s.cylinders.push_back(person_at(0.17f, 3.4f, 2, 1.75f));
  s.boxes.push_back({-0.9f, -0.2f, 0.0f, 0.7f, 3.2f, 3.7f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  const float area2 = visible_area(f, 2);
  const SegmenterConfig cfg = default_segmenter_config(false);
  ASSERT_LT(area2, cfg.min_person_area_m2) << "person 2 should show less than the person area";
  ASSERT_GT(area2, cfg.hidden_area_fraction * cfg.min_person_area_m2);

  SegmenterHarness h(cfg);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 2);
  int id2 = 0;
  for (size_t i = 0; i < f.truth.size() && id2 == 0; ++i)
    if (f.truth[i] == 2) id2 = h.labels[i];
  ASSERT_NE(id2, 0);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(id2), 2), int(0.9 * truth_pixels(f, 2)));
  EXPECT_EQ(count_pixels(h.labels, f, uint8_t(id2), 1), 0);
  EXPECT_EQ(labelled_truth(h.labels, f, 0), 0) << "the box behind person 1 is (part of) a user";

  // Without the relaxation person 2 is dropped.
  SegmenterConfig off = cfg;
  off.hidden_area_fraction = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  EXPECT_EQ(n.result.user_count, 1);
}

TEST(SegmentationCut, TheTwoSidesOfSomeoneHiddenBehindSomeoneElseAreOneUser) {
  // Person 2, broad and right behind person 1, shows a strip on either side of them, 0.7 m apart:
  // farther than fragment_radius_m, within hidden_pair_radius_m.
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 5.0f;
  s.cylinders.push_back(person_at(0.0f, 2.0f, 1));
  s.cylinders.push_back({0.0f, 3.4f, 0.37f, 0.0f, 1.75f, 2});
  const tools::RenderedScene f = tools::render_scene(s);
  int left = 0, right = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u)
      if (f.truth[size_t(v) * f.width + u] == 2) (u < f.width / 2 ? left : right)++;
  ASSERT_GT(left, 0);
  ASSERT_GT(right, 0);
  const SegmenterConfig cfg = default_segmenter_config(false);
  ASSERT_LT(visible_area(f, 2), 2.0f * cfg.min_person_area_m2);

  SegmenterHarness h(cfg);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  int id2 = 0;
  for (size_t i = 0; i < f.truth.size() && id2 == 0; ++i)
    if (f.truth[i] == 2) id2 = h.labels[i];
  ASSERT_NE(id2, 0);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(id2), 2), int(0.9 * truth_pixels(f, 2)));

  // Joined only by fragment_radius_m, the two strips are two users.
  SegmenterConfig near = cfg;
  near.hidden_pair_radius_m = 0.0f;
  EXPECT_EQ(users_found(near, f), 3);
}

TEST(SegmentationCut, ALegOfSomeoneHiddenBehindSomeoneElseJoinsThem) {
  // Person 2 behind person 1 shows a strip on one side (as high as a person, less than the person
  // area: passes only as hidden) and a leg on the other (as low as furniture: does not pass), the
  // two 0.6–0.8 m apart along the floor. The leg is smaller than the strip and hidden as well: it
  // joins the strip, within hidden_pair_radius_m.
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 5.0f;
  s.cylinders.push_back(person_at(0.0f, 2.0f, 1));
  s.cylinders.push_back(person_at(0.17f, 3.4f, 2, 1.75f));
  s.cylinders.push_back({-0.36f, 3.4f, 0.04f, 0.0f, 0.6f, 2});
  const tools::RenderedScene f = tools::render_scene(s);
  int strip = 0, leg = 0;
  double strip_area = 0.0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const size_t i = size_t(v) * f.width + u;
      if (f.truth[i] != 2) continue;
      (u < f.width / 2 ? leg : strip)++;
      const double z = f.depth_mm[i] * 0.001;
      if (u >= f.width / 2) strip_area += z * z / (double(f.intrinsics.fx) * f.intrinsics.fy);
    }
  ASSERT_GT(leg, 24) << "the leg should show";
  ASSERT_LT(leg, strip);
  const SegmenterConfig cfg = default_segmenter_config(false);
  ASSERT_LT(strip_area, cfg.min_person_area_m2) << "the strip should pass only as hidden";

  SegmenterHarness h(cfg);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  int id2 = 0;
  for (size_t i = 0; i < f.truth.size() && id2 == 0; ++i)
    if (f.truth[i] == 2) id2 = h.labels[i];
  ASSERT_NE(id2, 0);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(id2), 2), int(0.9 * truth_pixels(f, 2)))
      << "strip " << strip << " leg " << leg;
}

// An arm held out towards the camera, cut off from the body by the depth jump and crossed by a bar
// nearer still (which gives it hidden edges): a piece smaller than the person area, high enough,
// overlapping its body in the image and nearer than it. It passes only as someone mostly hidden,
// but someone hidden behind the body would be farther than the body: no second user.
TEST(SegmentationCut, AnArmInFrontOfItsBodyIsNoHiddenPerson) {
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 10.0f;
  s.cylinders.push_back(person_at(0.0f, 3.0f, 1));
  s.boxes.push_back({0.12f, 0.42f, 1.12f, 1.3f, 2.3f, 2.45f, 1});  // the forearm and hand
  s.boxes.push_back({0.22f, 2.6f, 1.15f, 1.19f, 1.5f, 1.55f, 0});  // a bar, wider than a person
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 1) << "the arm is a user of its own";
  EXPECT_GE(count_pixels(h.labels, f, 1, 1), int(0.8 * truth_pixels(f, 1)));
}

namespace {

// Someone bending over with the hands on the floor, the camera 1.2 m high looking level: the
// torso (z 1.3 m) and the arms hanging from it form one component; the legs, 0.55 m farther, show
// between the arms beyond a depth jump larger than fragment_join_mm, tall and large enough to pass
// the person test alone. `legs_z` moves the legs (or someone else) farther back.
tools::Scene bending_over(float legs_z) {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 0.0f;
  s.boxes.push_back({-0.35f, 0.35f, 1.1f, 1.6f, 1.3f, 1.45f, 1});    // torso
  s.boxes.push_back({-0.35f, -0.25f, 0.0f, 1.1f, 1.3f, 1.4f, 1});    // arms to the floor
  s.boxes.push_back({0.25f, 0.35f, 0.0f, 1.1f, 1.3f, 1.4f, 1});
  s.boxes.push_back({-0.15f, 0.15f, 0.0f, 1.05f, legs_z, legs_z + 0.12f, 2});  // legs
  return s;
}

}  // namespace

TEST(SegmentationCut, LegsSeenBetweenTheArmsOfSomeoneBendingOverJoinThem) {
  const tools::RenderedScene f = tools::render_scene(bending_over(1.85f));
  // Without the rule the legs are a user of their own (they pass alone and are neither touching,
  // nor stacked, nor within fragment_pair_radius_m of the body).
  SegmenterConfig off = default_segmenter_config(false);
  off.absorb_radius_m = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_TRUE(n.result.floor.valid);
  ASSERT_EQ(n.result.user_count, 2) << "the scene should make the legs pass on their own";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  const int id = h.result.users[0].id;
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(id), 1), int(0.95 * truth_pixels(f, 1)));
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(id), 2), int(0.95 * truth_pixels(f, 2)));
  EXPECT_EQ(h.result.users[0].pixel_count, count_pixels(h.labels, f, uint8_t(id), 1) +
                                                 count_pixels(h.labels, f, uint8_t(id), 2) +
                                                 count_pixels(h.labels, f, uint8_t(id), 0));
}

TEST(SegmentationCut, SomeoneFarBehindSeenBetweenTheArmsStaysAUser) {
  // The same outline 1.2 m behind the body: farther than absorb_radius_m, someone else.
  const tools::RenderedScene f = tools::render_scene(bending_over(2.5f));
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1) +
                count_pixels(h.labels, f, uint8_t(h.result.users[1].id), 1),
            int(0.95 * truth_pixels(f, 1)));
  int own = 0;
  for (int i = 0; i < h.result.user_count; ++i) own += count_pixels(h.labels, f, uint8_t(h.result.users[i].id), 2) > 0;
  EXPECT_EQ(own, 1) << "the one behind is one user";
}

namespace {

// An upper body that does not reach the floor (0.75-1.6 m high, front at z 2.4 m), and a leg
// stepping forward below it (0-0.6 m high, front at `leg_z`), apart from it in the image and in
// depth. The camera 1.0 m high looks level.
tools::Scene knee_forward(float leg_z) {
  tools::Scene s;
  s.camera.height_m = 1.0f;
  s.camera.pitch_deg = 0.0f;
  s.boxes.push_back({-0.25f, 0.25f, 0.75f, 1.6f, 2.4f, 2.55f, 1});
  s.boxes.push_back({0.0f, 0.3f, 0.0f, 0.6f, leg_z, leg_z + 0.12f, 1});
  return s;
}

}  // namespace

TEST(SegmentationCut, ALegSplitFromABodyAboveTheFloorJoinsIt) {
  // Centroids 0.52 m apart along the floor: beyond fragment_pair_radius_m, within legs_radius_m.
  const tools::RenderedScene f = tools::render_scene(knee_forward(1.9f));
  SegmenterConfig off = default_segmenter_config(false);
  off.legs_radius_m = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_TRUE(n.result.floor.valid);
  ASSERT_EQ(n.result.user_count, 1);
  ASSERT_LT(count_pixels(n.labels, f, uint8_t(n.result.users[0].id), 1), int(0.8 * truth_pixels(f, 1)))
      << "without the rule the leg should stay apart (the scene tests nothing otherwise)";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));
  EXPECT_LT(h.result.users[0].top_height_m, 1.7f);
}

TEST(SegmentationCut, APieceBelowABodyBeyondTheLegRadiusStaysApart) {
  // The same piece 0.7 m in front of the body (centroids 0.72 m apart): not its leg.
  const tools::RenderedScene f = tools::render_scene(knee_forward(1.7f));
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_LT(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.8 * truth_pixels(f, 1)));
}

namespace {

// box_split_height_m. A box 1.0 m wide and 0.7 m tall on the floor (truth 0) with
// someone standing against its side (truth 1): one component. The camera 1.2 m high looks
// slightly down.
tools::Scene person_against_box() {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 10.0f;
  s.boxes.push_back({-1.2f, -0.2f, 0.0f, 0.7f, 2.4f, 2.9f, 0});
  s.cylinders.push_back(person_at(0.0f, 2.65f, 1));
  return s;
}

// Someone crouching: the shins in front (0-0.5 m high) and the bent body above and behind them
// (0.5-1.05 m), in the same columns. The low part also reaches one height, but lies under the body.
tools::Scene crouching() {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 10.0f;
  s.boxes.push_back({-0.25f, 0.25f, 0.0f, 0.5f, 2.3f, 2.5f, 1});
  s.boxes.push_back({-0.25f, 0.25f, 0.5f, 1.05f, 2.5f, 2.8f, 1});
  return s;
}

// A box 0.6 m wide and 0.7 m tall (truth 0) with the arm of someone hidden behind it reaching
// 0.45 m above its lid (truth 2), touching it: one component higher than min_person_height_m,
// mostly the box.
tools::Scene box_with_arm() {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 10.0f;
  s.boxes.push_back({-0.5f, 0.1f, 0.0f, 0.7f, 2.5f, 2.9f, 0});
  s.boxes.push_back({-0.25f, -0.17f, 0.7f, 1.15f, 2.6f, 2.68f, 2});
  return s;
}

}  // namespace

TEST(SegmentationCut, ABoxWithAnArmOverItIsNoUser) {
  const tools::RenderedScene f = tools::render_scene(box_with_arm());
  ASSERT_GT(truth_pixels(f, 2), 0);
  SegmenterConfig off = default_segmenter_config(false);
  off.box_reject_min_share = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_TRUE(n.result.floor.valid);
  ASSERT_EQ(n.result.user_count, 1) << "without the rule the box and the arm should be a user (the scene tests nothing otherwise)";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_GT(h.segmenter.config().box_reject_min_share, 0.0f);
  ASSERT_EQ(h.run(f), Status::kOk);
  EXPECT_EQ(h.result.user_count, 0);
  EXPECT_EQ(labelled_truth(h.labels, f, 0) + labelled_truth(h.labels, f, 2), 0);
}

TEST(SegmentationCut, ABoxJoinedToSomeoneStandingAgainstItIsDropped) {
  const tools::RenderedScene f = tools::render_scene(person_against_box());
  SegmenterConfig off = default_segmenter_config(false);
  off.box_split_height_m = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_TRUE(n.result.floor.valid);
  ASSERT_EQ(n.result.user_count, 1);
  ASSERT_GT(labelled_truth(n.labels, f, 0), truth_pixels(f, 1))
      << "without the rule the box should be part of the user (the scene tests nothing otherwise)";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_GT(h.segmenter.config().box_split_height_m, 0.0f);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  const uint8_t id = uint8_t(h.result.users[0].id);
  EXPECT_GE(count_pixels(h.labels, f, id, 1), int(0.95 * truth_pixels(f, 1)));
  EXPECT_LT(labelled_truth(h.labels, f, 0), truth_pixels(f, 1) / 10) << "the box is background";
  EXPECT_EQ(h.result.users[0].pixel_count, count_pixels(h.labels, f, id, 0) + count_pixels(h.labels, f, id, 1));
}

TEST(SegmentationCut, SomeoneCrouchingKeepsTheirShins) {
  const tools::RenderedScene f = tools::render_scene(crouching());
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));

  // Without the distance test the shins would go (the scene tests the distance test).
  SegmenterConfig near = default_segmenter_config(false);
  near.box_split_min_dist_m = 0.0f;
  SegmenterHarness n(near);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_EQ(n.result.user_count, 1);
  EXPECT_LT(count_pixels(n.labels, f, uint8_t(n.result.users[0].id), 1), int(0.8 * truth_pixels(f, 1)));
}

namespace {

// A body 1.2 m tall (front at z 2.4 m) and, behind it at `head_z`, a narrow piece (0.16 m wide)
// reaching 0.9 m to `head_top` whose lower part the body hides: only the top shows above the body,
// less than a person's area, with an occluding edge below it. The camera 1.0 m high looks level.
tools::Scene head_behind(float head_z, float head_top, uint8_t head_truth) {
  tools::Scene s;
  s.camera.height_m = 1.0f;
  s.camera.pitch_deg = 0.0f;
  s.boxes.push_back({-0.25f, 0.25f, 0.0f, 1.2f, 2.4f, 2.6f, 1});
  s.boxes.push_back({-0.08f, 0.08f, 0.9f, head_top, head_z, head_z + 0.15f, head_truth});
  return s;
}

}  // namespace

TEST(SegmentationCut, TheTopOfABodyBeyondADepthJumpJoinsIt) {
  // 0.6 m behind the body's front: within head_radius_m, the same body.
  const tools::RenderedScene f = tools::render_scene(head_behind(3.0f, 1.55f, 1));
  SegmenterConfig off = default_segmenter_config(false);
  off.head_radius_m = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_TRUE(n.result.floor.valid);
  ASSERT_EQ(n.result.user_count, 2) << "without the rule the piece should be a user of its own";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));
  EXPECT_GT(h.result.users[0].top_height_m, 1.4f);
}

TEST(SegmentationCut, SomeoneFartherBehindShowingTheirHeadStaysAUser) {
  // 1.2 m behind the body's front: beyond head_radius_m, someone else.
  const tools::RenderedScene f = tools::render_scene(head_behind(3.6f, 1.6f, 2));
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 2);
  int own = 0;
  for (int i = 0; i < h.result.user_count; ++i) own += count_pixels(h.labels, f, uint8_t(h.result.users[i].id), 2) > 0;
  EXPECT_EQ(own, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 2) +
                count_pixels(h.labels, f, uint8_t(h.result.users[1].id), 2),
            int(0.95 * truth_pixels(f, 2)));
}

namespace {

// Someone at z 3.0 m behind a bar (z 1.8 m, 0.65–0.8 m high, wider than a person) that cuts them
// in two: an upper body (a box 0.4 m wide) above the bar, and the legs (a cylinder) below it,
// `legs_x` to the side (a step to the side, a leaning body: the centroids of the two pieces lie
// 0.4–0.6 m apart along the floor on the tuning seeds). The camera, 0.9 m high, looks level. The
// upper body passes the person test; the legs, lower than a person, do not, and they do not touch.
tools::Scene body_behind_bar(float legs_x, uint8_t legs_truth) {
  tools::Scene s;
  s.camera.height_m = 0.9f;
  s.camera.pitch_deg = 0.0f;
  s.boxes.push_back({-0.8f, 0.9f, 0.65f, 0.8f, 1.8f, 1.85f, 0});  // the bar
  s.boxes.push_back({-0.2f, 0.2f, 0.45f, 1.7f, 3.0f, 3.2f, 1});   // the upper body
  s.cylinders.push_back({legs_x, 3.1f, 0.1f, 0.0f, 0.75f, legs_truth});
  return s;
}

}  // namespace

TEST(SegmentationCut, TheLegsOfSomeonePartlyHiddenJoinThem) {
  const tools::RenderedScene f = tools::render_scene(body_behind_bar(0.45f, 1));
  SegmenterConfig off = default_segmenter_config(false);
  off.hidden_legs_radius_m = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_TRUE(n.result.floor.valid);
  ASSERT_EQ(n.result.user_count, 1);
  const int upper = count_pixels(n.labels, f, uint8_t(n.result.users[0].id), 1);
  ASSERT_LT(upper, int(0.8 * truth_pixels(f, 1))) << "without the rule the legs should stay out";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)))
      << "upper body alone " << upper << " of " << truth_pixels(f, 1);
  EXPECT_EQ(labelled_truth(h.labels, f, 0), 0);
}

TEST(SegmentationCut, ABoxBesideSomeonePartlyHiddenStaysApart) {
  // The same scene with a post (0.75 m high, 0.2 m wide) instead of the legs, 0.9 m beside the
  // upper body: beyond hidden_legs_radius_m it stays background (with a radius of 1 m it would
  // join like legs). The upper body stays a user.
  const tools::RenderedScene f = tools::render_scene(body_behind_bar(0.9f, 0));
  SegmenterConfig wide = default_segmenter_config(false);
  wide.hidden_legs_radius_m = 1.0f;
  SegmenterHarness w(wide);
  ASSERT_EQ(w.run(f), Status::kOk);
  ASSERT_EQ(w.result.user_count, 1);
  ASSERT_GT(labelled_truth(w.labels, f, 0), 0) << "with a 1 m radius the post should join";

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));
  EXPECT_EQ(labelled_truth(h.labels, f, 0), 0) << "the box joined the upper body";
}

TEST(SegmentationCut, ABoxInFrontOfSomeonesLegsIsNotTheirLegs) {
  // Someone (z 2.8–3.0 m) whose legs a box 0.5 m in front hides: the box stands on the floor, is
  // lower than the body and partly hidden itself (a post in front of it), within
  // hidden_legs_radius_m of the body along the floor, but it hides the body's lower edge across a
  // depth jump: it is in front of the body, not its legs.
  tools::Scene s;
  s.camera.height_m = 0.9f;
  s.camera.pitch_deg = 0.0f;
  s.boxes.push_back({-0.25f, 0.25f, 0.0f, 1.7f, 2.8f, 3.0f, 1});  // the body
  s.boxes.push_back({-0.35f, 0.35f, 0.0f, 0.7f, 2.2f, 2.3f, 0});  // the box
  s.cylinders.push_back({0.0f, 1.6f, 0.04f, 0.0f, 0.6f, 0});       // the post
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));
  EXPECT_EQ(labelled_truth(h.labels, f, 0), 0) << "the box joined the body";
}

// cut_fill_border_columns. A box cut by the top border fills its image box; a low
// box beside it and a little farther back, beyond a depth jump, touches it in the image. Measured
// over the union's box (widened by the low box and the empty rows above it) the two fill little,
// like legs.
tools::Scene box_with_low_box_beside(float low_x0) {
  tools::Scene s = low_camera();
  s.camera.roll_deg = 0.0f;
  s.camera.pitch_deg = 28.0f;
  s.boxes.push_back({-0.2f, 0.05f, 0.0f, 0.78f, 1.1f, 1.5f, 7});
  s.boxes.push_back({low_x0, low_x0 + 0.3f, 0.0f, 0.15f, 1.25f, 1.4f, 8});
  return s;
}

TEST(SegmentationCut, ABoxCutByTheTopBorderWithALowBoxBesideItIsNotAUser) {
  const tools::RenderedScene f = tools::render_scene(box_with_low_box_beside(0.1f));
  bool top = false, low_top = true;
  float fill = 0.0f, low_fill = 0.0f;
  truth_box(f, 7, &top, &fill);
  truth_box(f, 8, &low_top, &low_fill);
  ASSERT_TRUE(top);
  ASSERT_FALSE(low_top);
  ASSERT_GT(fill, 0.6f) << "the box alone should fill its image box";
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 0);
  EXPECT_EQ(labelled_truth(h.labels, f, 7), 0);
  // Over the union's box the two pass as someone cut by the border.
  SegmenterConfig off = default_segmenter_config(false);
  off.cut_fill_border_columns = 0;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_EQ(n.result.user_count, 1);
  EXPECT_GT(labelled_truth(n.labels, f, 7), 0);
  EXPECT_GT(labelled_truth(n.labels, f, 8), 0);
}

TEST(SegmentationCut, LegsSplitFromTheHipsByADepthJumpStayAUser) {
  // The legs a step nearer than the hips (a depth jump at the thighs): the hips touch the top
  // border, the legs below them do not. The legs share the hips' columns, so the union is still
  // measured over its whole box, legs apart, and passes.
  tools::Scene s = low_camera();
  s.camera.roll_deg = 0.0f;
  s.cylinders.push_back({-0.22f, 1.25f, 0.07f, 0.0f, 0.62f, 1});
  s.cylinders.push_back({0.22f, 1.25f, 0.07f, 0.0f, 0.62f, 1});
  s.boxes.push_back({-0.29f, 0.29f, 0.62f, 1.0f, 1.4f, 1.62f, 1});
  s.cylinders.push_back({0.0f, 1.5f, 0.2f, 1.0f, 1.7f, 1});
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  ASSERT_TRUE(top);
  for (int on = 0; on <= 1; ++on) {
    SegmenterConfig c = default_segmenter_config(false);
    c.cut_fill_border_columns = on;
    SegmenterHarness h(c);
    ASSERT_EQ(h.run(f), Status::kOk);
    ASSERT_TRUE(h.result.floor.valid);
    ASSERT_EQ(h.result.user_count, 1) << "cut_fill_border_columns=" << on;
    EXPECT_LT(h.result.users[0].top_height_m, 0.85f);
    EXPECT_GE(count_pixels(h.labels, f, 1, 1), int(0.9 * truth_pixels(f, 1))) << "cut_fill_border_columns=" << on;
  }
}

namespace {

// Σ z²/(fx·fy) over the pixels of `truth`: the body surface in view, as segeval counts it.
float truth_area_m2(const tools::RenderedScene& f, uint8_t truth) {
  double a = 0.0;
  for (size_t i = 0; i < f.truth.size(); ++i)
    if (f.truth[i] == truth && f.depth_mm[i] != 0) {
      const double z = f.depth_mm[i] * 1e-3;
      a += z * z / (double(f.intrinsics.fx) * f.intrinsics.fy);
    }
  return float(a);
}

// A low camera looking down steeply: someone 2.5 m away shows only their shins and feet under the
// top border.
tools::Scene steep_camera() {
  tools::Scene s;
  s.camera.height_m = 0.8f;
  s.camera.pitch_deg = 36.0f;
  s.camera.roll_deg = 2.0f;
  return s;
}

}  // namespace

// cut_top_area_fraction: the shins of someone far from a low camera, cut by the top
// border, have less than the person area; their silhouette still tells them from a box.
TEST(SegmentationCut, ShinsCutByTheTopBorderWithLessThanThePersonAreaAreAUser) {
  tools::Scene s = steep_camera();
  s.cylinders.push_back({-0.42f, 2.5f, 0.03f, 0.0f, 0.7f, 1});  // thin shins, 0.24 m apart
  s.cylinders.push_back({-0.18f, 2.5f, 0.03f, 0.0f, 0.7f, 1});
  s.boxes.push_back({-0.45f, -0.15f, 0.0f, 0.05f, 2.45f, 2.55f, 1});  // the feet join them
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  ASSERT_TRUE(top) << "the scene should cut the shins at the top border";
  ASSERT_LT(fill, 0.6f);
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(on.cut_top_area_fraction, 0.0f);
  const float area = truth_area_m2(f, 1);
  ASSERT_LT(area, on.min_person_area_m2) << "the scene should show less than the person area";
  ASSERT_GT(area, 0.0f);
  ASSERT_GT(area, on.cut_top_area_fraction * on.min_person_area_m2 * 1.1f);

  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, 1, 1), int(0.9 * truth_pixels(f, 1)));

  // With the rule off they are too small.
  SegmenterConfig off = on;
  off.cut_top_area_fraction = 0.0f;
  EXPECT_EQ(users_found(off, f), 0);
}

TEST(SegmentationCut, ASmallBoxCutByTheTopBorderStaysNoUser) {
  // The same place and the same area as the shins above, but solid: it fills its image box and its
  // hull, and the smaller area needed does not make it a person.
  tools::Scene s = steep_camera();
  s.boxes.push_back({-0.38f, -0.22f, 0.0f, 0.78f, 2.42f, 2.58f, 1});
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  ASSERT_TRUE(top);
  ASSERT_GT(fill, 0.8f);
  const SegmenterConfig on = default_segmenter_config(false);
  const float area = truth_area_m2(f, 1);
  ASSERT_LT(area, on.min_person_area_m2);
  ASSERT_GT(area, on.cut_top_area_fraction * on.min_person_area_m2);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 0);
  EXPECT_GT(h.result.component_count, 0);
}

namespace {

// Two shins joined by the feet, cut by the top border of steep_camera().
void add_shins(tools::Scene* s, float x, float z, float radius, uint8_t truth) {
  s->cylinders.push_back({x - 0.12f, z, radius, 0.0f, 0.7f, truth});
  s->cylinders.push_back({x + 0.12f, z, radius, 0.0f, 0.7f, truth});
  s->boxes.push_back({x - 0.15f, x + 0.15f, 0.0f, 0.05f, z - 0.05f, z + 0.05f, truth});
}

int users_with(const SegmenterHarness& h, const tools::RenderedScene& f, uint8_t truth) {
  int n = 0;
  for (int id = 1; id <= 15; ++id) n += count_pixels(h.labels, f, uint8_t(id), truth) > 0;
  return n;
}

}  // namespace

TEST(SegmentationCut, ASmallPieceCutByTheTopBorderNearAUserCutThereJoinsIt) {
  // A larger piece with the full area (truth 1) and, 0.2 m behind and 0.45 m aside, a smaller one
  // with 0.8-1 of it (truth 2, standing for the other leg): with cut_top_area_fraction the smaller
  // passes and, within legs_radius_m of the larger user, joins it rather than making a second user.
  tools::Scene s = steep_camera();
  add_shins(&s, 0.15f, 2.3f, 0.05f, 1);
  add_shins(&s, -0.3f, 2.5f, 0.03f, 2);
  const tools::RenderedScene f = tools::render_scene(s);
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(truth_area_m2(f, 1), on.min_person_area_m2);
  ASSERT_LT(truth_area_m2(f, 2), on.min_person_area_m2);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 1);
  EXPECT_EQ(users_with(h, f, 1), 1);
  EXPECT_EQ(users_with(h, f, 2), 1);
  // Without the join the smaller piece is a second user.
  SegmenterConfig no_join = on;
  no_join.legs_radius_m = 0.0f;
  EXPECT_EQ(users_found(no_join, f), 2);
  // With the rule off the smaller piece is left out.
  SegmenterConfig off = on;
  off.cut_top_area_fraction = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  EXPECT_EQ(n.result.user_count, 1);
  EXPECT_EQ(users_with(n, f, 2), 0);
}

TEST(SegmentationCut, ASmallPieceCutByTheTopBorderFarFromAUserStaysAUser) {
  // The same pieces 1.2 m apart: someone else's shins, a user of their own.
  tools::Scene s = steep_camera();
  add_shins(&s, 0.9f, 2.3f, 0.05f, 1);
  add_shins(&s, -0.3f, 2.5f, 0.03f, 2);
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 2);
  EXPECT_EQ(users_with(h, f, 1), 1);
  EXPECT_EQ(users_with(h, f, 2), 1);
  // With the rule off the smaller one is too small to be a user.
  SegmenterConfig off = default_segmenter_config(false);
  off.cut_top_area_fraction = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  EXPECT_EQ(n.result.user_count, 1);
  EXPECT_EQ(users_with(n, f, 2), 0);
}

namespace {

// low_max_lid_share. Someone low over the floor (crouching, on all fours), as four
// steps one behind the other whose tops reach 0.2, 0.4, 0.6 and 0.78 m (feet, knees, hips, head):
// lower than min_person_height_m, like furniture, but its cells on the floor reach many heights.
// The camera 1.2 m high looks slightly down.
tools::Scene low_body(uint8_t truth) {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 10.0f;
  const float tops[4] = {0.2f, 0.4f, 0.6f, 0.78f};
  for (int i = 0; i < 4; ++i)
    s.boxes.push_back({-0.3f + 0.03f * float(i), 0.3f - 0.03f * float(i), 0.0f, tops[i], 2.2f + 0.2f * float(i),
                       2.4f + 0.2f * float(i), truth});
  return s;
}

}  // namespace

TEST(SegmentationCut, SomeoneLowOverTheFloorIsAUser) {
  const tools::RenderedScene f = tools::render_scene(low_body(1));
  ASSERT_GT(truth_pixels(f, 1), 0);
  // Without the rule: too low for the height test, no user (the scene tests the rule).
  SegmenterConfig off = default_segmenter_config(false);
  off.low_max_lid_share = 0.0f;
  SegmenterHarness n(off);
  ASSERT_EQ(n.run(f), Status::kOk);
  ASSERT_TRUE(n.result.floor.valid);
  ASSERT_EQ(n.result.user_count, 0);

  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_GT(h.segmenter.config().low_max_lid_share, 0.0f);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_LT(h.result.users[0].top_height_m, h.segmenter.config().min_person_height_m);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));

  // Lower than low_min_height_m it is not judged this way.
  SegmenterConfig high = default_segmenter_config(false);
  high.low_min_height_m = 0.8f;
  SegmenterHarness m(high);
  ASSERT_EQ(m.run(f), Status::kOk);
  EXPECT_EQ(m.result.user_count, 0);
}

TEST(SegmentationCut, ABoxAsLowAsSomeoneLowOverTheFloorIsNoUser) {
  // A solid box with the same footprint and top (0.78 m): every cell reaches its lid.
  tools::Scene s = low_body(1);
  s.boxes.clear();
  s.boxes.push_back({-0.3f, 0.3f, 0.0f, 0.78f, 2.2f, 3.0f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_GT(truth_pixels(f, 0), 0);
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_GT(h.segmenter.config().low_max_lid_share, 0.0f);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 0);
  // It has the area and stands on the floor: with any lid share allowed it would be a user (the
  // scene tests the lid share, not the other conditions).
  SegmenterConfig any = default_segmenter_config(false);
  any.low_max_lid_share = 1.0f;
  SegmenterHarness a(any);
  ASSERT_EQ(a.run(f), Status::kOk);
  EXPECT_EQ(a.result.user_count, 1);
}

namespace {

// Hips and thighs (a solid block, wider) over two shins standing close together, cut by the top
// border of low_camera(): the silhouette fills more than cut_max_fill of its image box and more
// than cut_max_solidity of its hull, but the floor shows between the shins. With `apart` false
// the shins are one solid block of the same outer width (no gap).
void add_legs_together(tools::Scene* s, float x, float z, bool apart, uint8_t truth) {
  s->boxes.push_back({x - 0.22f, x + 0.22f, 0.35f, 1.0f, z - 0.1f, z + 0.1f, truth});
  if (apart) {
    s->cylinders.push_back({x - 0.09f, z, 0.07f, 0.0f, 0.4f, truth});
    s->cylinders.push_back({x + 0.09f, z, 0.07f, 0.0f, 0.4f, truth});
  } else {
    s->boxes.push_back({x - 0.16f, x + 0.16f, 0.0f, 0.4f, z - 0.07f, z + 0.07f, truth});
  }
}

}  // namespace

// cut_gap_min_share: legs cut by the top border, close together, pass the
// silhouette test by the rows where the floor shows between them.
TEST(SegmentationCut, LegsTogetherCutByTheTopBorderAreAUserByTheGapBetweenThem) {
  tools::Scene s = low_camera();
  add_legs_together(&s, -0.1f, 1.5f, true, 1);
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(on.cut_gap_min_share, 0.0f);
  ASSERT_TRUE(top) << "the scene should cut the legs at the top border";
  ASSERT_GT(fill, on.cut_max_fill) << "the fill test alone should refuse them";
  ASSERT_LT(fill, on.cut_gap_max_fill);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.9 * truth_pixels(f, 1)));
  // With the rule off the fill and hull tests refuse them.
  SegmenterConfig off = on;
  off.cut_gap_min_share = 0.0f;
  EXPECT_EQ(users_found(off, f), 0);
}

TEST(SegmentationCut, TheSameOutlineWithoutAGapCutByTheTopBorderStaysNoUser) {
  // The same block with the shins as one solid piece (a box or a cabinet on a plinth): no row shows
  // the floor between two runs, so the rule does not pass it.
  tools::Scene s = low_camera();
  add_legs_together(&s, -0.1f, 1.5f, false, 1);
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  ASSERT_TRUE(top);
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(fill, on.cut_max_fill);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 0);
  EXPECT_GT(h.result.component_count, 0);
  // Nor is a solid outline filling more than cut_gap_max_fill passed by a gap: the legs above with
  // the cap at the cut_max_fill level stay no user.
  tools::Scene g = low_camera();
  add_legs_together(&g, -0.1f, 1.5f, true, 1);
  SegmenterConfig capped = on;
  capped.cut_gap_max_fill = on.cut_max_fill;
  EXPECT_EQ(users_found(capped, tools::render_scene(g)), 0);
}

// cut_hidden_floor_contact_m: legs cut by the top border whose feet a nearer box
// hides stand higher than cut_floor_contact_m above the floor; their downward edges are hidden.
namespace {

// Two legs apart joined by the hips; the top border (about 0.79 m up at 1.6 m) shows the shins,
// the knees and a thin band of the hips.
void add_shins(tools::Scene* s, float x, float z, uint8_t truth) {
  s->cylinders.push_back({x - 0.22f, z, 0.07f, 0.0f, 0.9f, truth});
  s->cylinders.push_back({x + 0.22f, z, 0.07f, 0.0f, 0.9f, truth});
  s->boxes.push_back({x - 0.29f, x + 0.29f, 0.74f, 1.0f, z - 0.07f, z + 0.07f, truth});
}

}  // namespace

TEST(SegmentationCut, LegsCutByTheTopBorderWithTheirFeetHiddenByABoxAreAUser) {
  tools::Scene s = low_camera();
  add_shins(&s, -0.45f, 1.6f, 1);
  s.boxes.push_back({-0.95f, 0.05f, 0.0f, 0.55f, 0.9f, 1.1f, 0});  // a low box in front, hiding the feet
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(on.cut_hidden_floor_contact_m, on.cut_floor_contact_m);
  ASSERT_TRUE(top) << "the scene should cut the shins at the top border";
  ASSERT_LT(fill, on.cut_max_fill);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.9 * truth_pixels(f, 1)));
  EXPECT_EQ(labelled_truth(h.labels, f, 0), 0) << "the box in front is no part of the user";
  // With the rule off the floor-contact test refuses them: their lowest point is over 0.3 m up.
  SegmenterConfig off = on;
  off.cut_hidden_floor_contact_m = 0.0f;
  EXPECT_EQ(users_found(off, f), 0);
  // Without the box the feet show and they are a user with the rule off too.
  tools::Scene open = low_camera();
  add_shins(&open, -0.45f, 1.6f, 1);
  EXPECT_EQ(users_found(off, tools::render_scene(open)), 1);
}

TEST(SegmentationCut, ABoxCutByTheTopBorderWithItsBottomHiddenStaysNoUser) {
  // A cupboard cut by the top border behind a low box that hides its bottom: off the floor by the
  // same amount, its solid outline still fails the silhouette tests with the rule on.
  tools::Scene s = low_camera();
  s.boxes.push_back({-0.75f, -0.15f, 0.0f, 0.8f, 1.5f, 1.9f, 1});
  s.boxes.push_back({-0.95f, 0.05f, 0.0f, 0.55f, 0.9f, 1.1f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  bool top = false;
  float fill = 0.0f;
  truth_box(f, 1, &top, &fill);
  ASSERT_TRUE(top) << "the scene should cut the cupboard at the top border";
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(on.cut_hidden_floor_contact_m, 0.0f);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_GT(h.result.component_count, 0);
  EXPECT_EQ(h.result.user_count, 0);
  // The same outline with a gap between two legs would pass (the test above): what keeps the
  // cupboard out is its fill, not the floor contact.
  SegmenterConfig loose = on;
  loose.cut_max_fill = 1.0f;
  SegmenterHarness l(loose);
  ASSERT_EQ(l.run(f), Status::kOk);
  EXPECT_EQ(l.result.user_count, 1) << "with its hidden bottom waived and no fill test it passes";
}

namespace {

// low_max_solidity. Someone kneeling bent over, seen from the side 2.5 m away by
// the camera of low_body(): the back a flat slab 0.6-0.78 m high over arms and thighs, the head
// hanging lower in front of the shoulders, the shins flat on the floor behind the knees. Most of
// its cells reach the back's height (a lid share over low_max_lid_share), but the floor shows
// between arms and thighs under the back: its outline fills little of its hull.
tools::Scene bent_over_body(uint8_t truth) {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 10.0f;
  s.boxes.push_back({-0.35f, 0.25f, 0.6f, 0.78f, 2.4f, 2.6f, truth});   // back
  s.cylinders.push_back({-0.3f, 2.5f, 0.05f, 0.0f, 0.6f, truth});        // arms
  s.cylinders.push_back({0.2f, 2.5f, 0.07f, 0.0f, 0.6f, truth});         // thighs
  s.boxes.push_back({-0.6f, -0.36f, 0.35f, 0.6f, 2.42f, 2.58f, truth});  // head
  s.boxes.push_back({0.25f, 0.65f, 0.0f, 0.14f, 2.43f, 2.57f, truth});   // shins
  return s;
}

}  // namespace

TEST(SegmentationCut, SomeoneBentOverWhoseBackIsALidIsAUserByTheOutline) {
  const tools::RenderedScene f = tools::render_scene(bent_over_body(1));
  ASSERT_GT(truth_pixels(f, 1), 0);
  SegmenterConfig off = default_segmenter_config(false);
  off.low_max_solidity = 0.0f;
  EXPECT_EQ(users_found(off, f), 0) << "the lid share alone keeps it out (the scene tests the outline)";
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_GT(h.segmenter.config().low_max_solidity, 0.0f);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_LT(h.result.users[0].top_height_m, h.segmenter.config().min_person_height_m);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));
}

TEST(SegmentationCut, ATableAsLowAsSomeoneBentOverStaysNoUser) {
  // A table of the same footprint and height: a top 0.72-0.78 m high on four legs. Its outline
  // leaves the floor between the legs, like the body above, but every cell reaches the top.
  tools::Scene s = bent_over_body(1);
  s.boxes.clear();
  s.cylinders.clear();
  s.boxes.push_back({-0.6f, 0.65f, 0.72f, 0.78f, 2.4f, 2.6f, 0});
  for (float x : {-0.55f, 0.6f})
    for (float z : {2.45f, 2.55f}) s.cylinders.push_back({x, z, 0.03f, 0.0f, 0.72f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_GT(truth_pixels(f, 0), 0);
  SegmenterConfig cfg = default_segmenter_config(false);
  ASSERT_GT(cfg.low_max_solidity, 0.0f);
  EXPECT_EQ(users_found(cfg, f), 0);
  // Its outline alone would pass (the scene tests the cap on the lid share).
  SegmenterConfig any = cfg;
  any.low_outline_max_lid_share = 1.0f;
  EXPECT_EQ(users_found(any, f), 1);
}

TEST(SegmentationCut, SomeoneBentOverBesideABoxIsNoUserByTheOutline) {
  // The same body with a box 0.4 m wide and 0.5 m high beside it, touching the shins: one
  // component, too low for the height test. Its outline passes, but the box's lid holds a large
  // share of it and lies apart from the rest (low_outline_box_split): no user, where without that
  // test it is one (a body and a box as one user).
  tools::Scene s = bent_over_body(1);
  s.boxes.push_back({0.65f, 1.05f, 0.0f, 0.5f, 2.4f, 2.6f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterConfig cfg = default_segmenter_config(false);
  ASSERT_NE(cfg.low_outline_box_split, 0);
  EXPECT_EQ(users_found(cfg, f), 0);
  SegmenterConfig no_split = cfg;
  no_split.low_outline_box_split = 0;
  EXPECT_EQ(users_found(no_split, f), 1);
}

// pair_bridge_max_m: two people joined by an arm.
namespace {

// Two people 0.9 m apart, 3 m from a camera 1.3 m high; person 1 holds an arm out at shoulder
// height (1.25-1.35 m) to person 2's side, touching them: one component 1.3 m wide.
tools::Scene two_people_joined_by_an_arm() {
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 12.0f;
  s.cylinders.push_back(person_at(-0.45f, 3.0f, 1));
  s.cylinders.push_back(person_at(0.45f, 3.0f, 2));
  s.boxes.push_back({-0.3f, 0.3f, 1.25f, 1.35f, 2.88f, 2.98f, 1});
  return s;
}

}  // namespace

TEST(SegmentationCut, TwoPeopleJoinedByAnArmAreTwoUsers) {
  const tools::RenderedScene f = tools::render_scene(two_people_joined_by_an_arm());
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(on.pair_bridge_max_m, 0.0f);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 2);
  // Each user is one person (the arm is cut in its middle: person 1 keeps its body and half the arm).
  for (uint8_t truth = 1; truth <= 2; ++truth) {
    int best = 0;
    for (int i = 0; i < h.result.user_count; ++i) {
      const int mine = count_pixels(h.labels, f, uint8_t(h.result.users[i].id), truth);
      if (mine > best) best = mine;
      const int other = count_pixels(h.labels, f, uint8_t(h.result.users[i].id), uint8_t(3 - truth));
      if (mine > other) {
        EXPECT_LT(other, h.result.users[i].pixel_count / 10) << "a user holds both people";
      }
    }
    EXPECT_GE(best, int(0.9 * truth_pixels(f, truth))) << "person " << int(truth);
  }
  // With the rule off both are one component that passes the person test: one user.
  SegmenterConfig off = on;
  off.pair_bridge_max_m = 0.0f;
  EXPECT_EQ(users_found(off, f), 1);
  // Apart (no arm), they are two users either way.
  tools::Scene apart = two_people_joined_by_an_arm();
  apart.boxes.clear();
  EXPECT_EQ(users_found(off, tools::render_scene(apart)), 2);
}

TEST(SegmentationCut, APersonWithLegsApartAndAnArmHeldOutStaysOneUser) {
  // One body: legs 0.44 m apart under a torso (0.8-1.45 m), a head, and an arm held out 0.55 m to
  // the side at shoulder height. The slices between the legs are not thin (torso above, lowest
  // point 0.8 m) and beyond the arm nothing stands on the floor: no cut, even with a loose bridge.
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 12.0f;
  s.cylinders.push_back({-0.22f, 3.0f, 0.08f, 0.0f, 0.85f, 1});
  s.cylinders.push_back({0.22f, 3.0f, 0.08f, 0.0f, 0.85f, 1});
  s.boxes.push_back({-0.2f, 0.2f, 0.8f, 1.45f, 2.9f, 3.1f, 1});
  s.cylinders.push_back({0.0f, 3.0f, 0.1f, 1.45f, 1.7f, 1});
  s.boxes.push_back({0.2f, 0.75f, 1.3f, 1.38f, 2.95f, 3.03f, 1});
  const tools::RenderedScene f = tools::render_scene(s);
  for (const float bridge : {0.4f, 1.0f}) {
    SegmenterConfig cfg = default_segmenter_config(false);
    cfg.pair_bridge_max_m = bridge;
    SegmenterHarness h(cfg);
    ASSERT_EQ(h.run(f), Status::kOk);
    ASSERT_EQ(h.result.user_count, 1) << "pair_bridge_max_m " << bridge;
    EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.97 * truth_pixels(f, 1)));
  }
}

TEST(SegmentationCut, APersonWithAnArmOnABoxLeavesTheBoxNoUser) {
  // Someone rests a forearm on a 0.8 m box beside them: one component, and the box with the arm on
  // it reaches from the floor to 0.9 m like a standing slice. The arm over the gap lies lower than
  // min_person_height_m, so it is no bridge: the box does not become a user of its own, and the
  // rule labels no more of it than without it (the box split leaves the pixels of
  // the cells under the arm with the person either way).
  tools::Scene s;
  s.camera.height_m = 1.3f;
  s.camera.pitch_deg = 12.0f;
  s.cylinders.push_back(person_at(-0.45f, 3.0f, 1));
  s.boxes.push_back({0.1f, 0.8f, 0.0f, 0.8f, 2.8f, 3.2f, 0});
  s.boxes.push_back({-0.3f, 0.3f, 0.8f, 0.9f, 2.86f, 2.96f, 1});
  const tools::RenderedScene f = tools::render_scene(s);
  int box_labelled_off = -1;
  for (const float bridge : {0.0f, 0.4f, 1.0f}) {
    SegmenterConfig cfg = default_segmenter_config(false);
    cfg.pair_bridge_max_m = bridge;
    SegmenterHarness h(cfg);
    ASSERT_EQ(h.run(f), Status::kOk);
    ASSERT_TRUE(h.result.floor.valid);
    ASSERT_EQ(h.result.user_count, 1) << "pair_bridge_max_m " << bridge;
    EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.97 * truth_pixels(f, 1)));
    const int box_labelled = labelled_truth(h.labels, f, 0);
    if (box_labelled_off < 0) box_labelled_off = box_labelled;
    EXPECT_EQ(box_labelled, box_labelled_off) << "pair_bridge_max_m " << bridge;
    EXPECT_LT(box_labelled, truth_pixels(f, 1) / 10);
  }
}

// cut_bottom_low_max_lid_share: someone low over the floor cut by the bottom border.
namespace {

// A camera 1.2 m high looking 10° down and someone kneeling 1.1-1.6 m in front of it, the body
// rising in steps away from the camera: the folded legs up to 0.5 m, the torso up to 0.68 m, the
// head up to 0.8 m, the arms hanging beside the legs. The bottom image border cuts the legs above
// cut_floor_contact_m, so the floor under them is out of view; the cells reach several heights.
tools::Scene crouching_close(uint8_t truth) {
  tools::Scene s;
  s.camera.height_m = 1.2f;
  s.camera.pitch_deg = 10.0f;
  s.boxes.push_back({-0.2f, 0.2f, 0.0f, 0.5f, 1.1f, 1.25f, truth});    // folded legs
  s.boxes.push_back({-0.2f, 0.2f, 0.3f, 0.68f, 1.25f, 1.45f, truth});  // torso
  s.boxes.push_back({-0.1f, 0.1f, 0.5f, 0.8f, 1.45f, 1.6f, truth});    // head
  s.cylinders.push_back({-0.25f, 1.2f, 0.05f, 0.0f, 0.55f, truth});    // arms
  s.cylinders.push_back({0.25f, 1.2f, 0.05f, 0.0f, 0.55f, truth});
  return s;
}

// The lowest height above the floor of truth `truth` in the bottom image row (−1: none there).
float bottom_row_height(const tools::RenderedScene& f, const tools::Scene& s, uint8_t truth) {
  float n[3], d;
  tools::floor_plane_in_camera(s.camera, n, &d);
  float low = -1.0f;
  const int v = f.height - 1;
  for (int u = 0; u < f.width; ++u) {
    const size_t i = size_t(v) * f.width + u;
    if (f.truth[i] != truth || f.depth_mm[i] == 0) continue;
    const float z = f.depth_mm[i] * 0.001f;
    const float x = (u - f.intrinsics.cx) * z / f.intrinsics.fx, y = -(v - f.intrinsics.cy) * z / f.intrinsics.fy;
    const float up = n[0] * x + n[1] * y + n[2] * z + d;
    if (low < 0.0f || up < low) low = up;
  }
  return low;
}

}  // namespace

TEST(SegmentationCut, SomeoneCrouchingCutByTheBottomBorderAboveTheFloorIsAUser) {
  const tools::Scene s = crouching_close(1);
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_GT(truth_pixels(f, 1), 0);
  const SegmenterConfig on = default_segmenter_config(false);
  ASSERT_GT(on.cut_bottom_low_max_lid_share, 0.0f);
  // The scene: cut by the bottom border above cut_floor_contact_m, top below the height test.
  ASSERT_GT(bottom_row_height(f, s, 1), on.cut_floor_contact_m);
  SegmenterHarness h(on);
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_EQ(h.result.users[0].v_max, f.height - 1);
  EXPECT_LT(h.result.users[0].top_height_m, on.min_person_height_m);
  EXPECT_GE(h.result.users[0].top_height_m, on.low_min_height_m);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * truth_pixels(f, 1)));
  SegmenterConfig off = on;
  off.cut_bottom_low_max_lid_share = 0.0f;
  EXPECT_EQ(users_found(off, f), 0) << "without the rule nothing judges a low component off the floor";
}

TEST(SegmentationCut, ABoxCutByTheBottomBorderAboveTheFloorStaysNoUser) {
  // A box of the same footprint and nearly the same height (0.78 m, as tall as the clutter gets) at
  // the same place: cut by the bottom border above the floor too, but every cell reaches its lid.
  tools::Scene s = crouching_close(1);
  s.boxes.clear();
  s.cylinders.clear();
  s.boxes.push_back({-0.3f, 0.3f, 0.0f, 0.78f, 1.15f, 1.6f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  ASSERT_GT(truth_pixels(f, 0), 0);
  const SegmenterConfig on = default_segmenter_config(false);
  EXPECT_EQ(users_found(on, f), 0);
  SegmenterConfig off = on;
  off.cut_bottom_low_max_lid_share = 0.0f;
  EXPECT_EQ(users_found(off, f), 0);
  // Its area, width, height and position would pass (the scene tests the lid share).
  SegmenterConfig any = on;
  any.cut_bottom_low_max_lid_share = 1.0f;
  EXPECT_EQ(users_found(any, f), 1);
}

TEST(SegmentationCut, ABoxCutByTheBottomBorderPartlyHiddenStaysNoUser) {
  // The same box behind a post that hides part of it: what the post hides may be the rest of the lid,
  // so the lid share is not trusted (cut_solidity_max_hidden), whatever its cap.
  tools::Scene s = crouching_close(1);
  s.boxes.clear();
  s.cylinders.clear();
  s.boxes.push_back({-0.3f, 0.3f, 0.0f, 0.78f, 1.15f, 1.6f, 0});
  s.cylinders.push_back({0.0f, 0.9f, 0.06f, 0.0f, 0.8f, 0});
  const tools::RenderedScene f = tools::render_scene(s);
  SegmenterConfig any = default_segmenter_config(false);
  any.cut_bottom_low_max_lid_share = 1.0f;
  EXPECT_EQ(users_found(any, f), 0);
  // With the hidden part allowed the box passes (the scene tests the occlusion condition).
  any.cut_solidity_max_hidden = 1.0f;
  EXPECT_EQ(users_found(any, f), 1);
}

namespace {

// A thin slab standing on the floor 2.5 m away whose inner `shown_m` lies inside the right
// image border (the rest beyond it), `height_m` tall: someone at the edge of the view, or clutter.
tools::Scene side_scene(float shown_m, float height_m, float* need_px) {
  tools::Scene s;
  s.camera.height_m = 1.0f;
  s.camera.pitch_deg = 0.0f;
  const DepthFrame probe = tools::render_scene(s).view();
  const CameraIntrinsics& k = probe.intrinsics;
  const float z0 = 2.5f, z1 = 2.52f;  // thin: its left face, seen obliquely, adds little
  const float edge = (float(probe.width) - 0.5f - k.cx) * z0 / k.fx;  // the right border at z0
  s.boxes.push_back({edge - shown_m, edge + 0.4f, 0.0f, height_m, z0, z1, 1});
  *need_px = default_segmenter_config(false).min_person_area_m2 * k.fx * k.fy / (z0 * z0);
  return s;
}

}  // namespace

TEST(SegmentationCut, APersonCutByTheSideBorderIsAUser) {
  // Someone at the right edge of the view: a strip 1.7 m high shows, thinner than the person area
  // asks; the height and the footing are in view (cut_side_area_fraction).
  float need = 0.0f;
  const tools::RenderedScene f = tools::render_scene(side_scene(0.015f, 1.7f, &need));
  const int shown = truth_pixels(f, 1);
  ASSERT_LT(float(shown), need) << "the strip should be short of the person area";
  ASSERT_GE(float(shown), 0.65f * need) << "the strip should hold more than cut_side_area_fraction of the person area";
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  ASSERT_EQ(h.result.user_count, 1);
  EXPECT_EQ(h.result.users[0].u_max, f.width - 1);
  EXPECT_GE(count_pixels(h.labels, f, uint8_t(h.result.users[0].id), 1), int(0.95 * shown));
  SegmenterConfig off = default_segmenter_config(false);
  off.cut_side_area_fraction = 0.0f;
  EXPECT_EQ(users_found(off, f), 0) << "with the rule off the strip should be no user";
}

TEST(SegmentationCut, ClutterCutByTheSideBorderIsNotAUser) {
  // A box 0.8 m tall (the synthetic clutter is 0.3-0.8 m) cut the same way, with the same share of
  // the person area: too low for a person, with the rule on or off.
  float need = 0.0f;
  const tools::RenderedScene f = tools::render_scene(side_scene(0.05f, 0.8f, &need));
  const int shown = truth_pixels(f, 1);
  ASSERT_LT(float(shown), need);
  ASSERT_GE(float(shown), 0.65f * need) << "the box should hold more than cut_side_area_fraction of the person area";
  SegmenterHarness h(default_segmenter_config(false));
  ASSERT_EQ(h.run(f), Status::kOk);
  ASSERT_TRUE(h.result.floor.valid);
  EXPECT_EQ(h.result.user_count, 0);
  SegmenterConfig low = default_segmenter_config(false);
  low.cut_side_area_fraction = 0.1f;
  EXPECT_EQ(users_found(low, f), 0);
}
