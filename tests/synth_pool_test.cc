// The pose pool: the grid-accelerated furthest-neighbour selection against the plain scan, mirror
// images, rotation noise that keeps elbows and knees hinges, upper/lower-body recombination, the
// per-category report, determinism, the pose cache (a pool from cached real poses equals the fresh
// one bit for bit; a cache for other inputs or a damaged file is refused, saying why), and the
// pose sheet of the CLI.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include <png.h>
#include <unistd.h>

#include "tests/cli_test_support.h"
#include "tests/shared_data.h"
#include "tools/common/png_io.h"
#include "tools/synth/clip_index.h"
#include "tools/synth/pose_cache.h"
#include "tools/synth/pose_pool.h"
#include "tools/synth/synth.h"

namespace dp::synth {
namespace {
namespace fs = std::filesystem;

const std::string kAssets = dp::test::shared_path("assets");

std::vector<JointSet> random_clusters(uint64_t seed, int clusters, int per_cluster, double spread) {
  uint64_t s = seed;
  auto rnd = [&]() {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return double(s >> 11) / double(1ull << 53);
  };
  std::vector<JointSet> items;
  for (int c = 0; c < clusters; ++c) {
    JointSet centre;
    for (auto& p : centre) p = {rnd() * 1.5 - 0.75, rnd() * 1.8 - 0.9, rnd() * 1.0 - 0.5};
    for (int i = 0; i < per_cluster; ++i) {
      JointSet j = centre;
      for (auto& p : j) p += Vec3{(rnd() - 0.5) * spread, (rnd() - 0.5) * spread, (rnd() - 0.5) * spread};
      items.push_back(j);
    }
  }
  return items;
}

TEST(SynthPosePool, GridSelectionEqualsThePlainScan) {
  for (uint64_t seed : {1, 2, 3})
    for (double d : {0.02, 0.05, 0.12, 0.4}) {
      const std::vector<JointSet> items = random_clusters(seed, 40, 30, 0.3);
      EXPECT_EQ(furthest_neighbour_selection(items, d), furthest_neighbour_selection_reference(items, d))
          << "seed " << seed << " D " << d;
    }
  // Duplicates and a single item.
  std::vector<JointSet> same(5, random_clusters(9, 1, 1, 0)[0]);
  EXPECT_EQ(furthest_neighbour_selection(same, 0.05), std::vector<size_t>{0});
  EXPECT_TRUE(furthest_neighbour_selection({}, 0.05).empty());
}

class SynthPosePoolSharedData : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(fs::exists(kAssets + "/mocap/clips.tsv")) << "shared assets missing under " << kAssets;
    assets_ = std::make_unique<HumanAssets>(load_human_assets(kAssets));
    std::vector<ClipEntry> entries;
    clips_ = std::make_unique<std::vector<MotionClip>>(
        load_clips(kAssets, {"02_01", "60_01", "105_13"}, 8, kDefaultSplitsPath, &entries));
    for (const ClipEntry& e : entries) categories_.push_back(e.category);
  }
  static void TearDownTestSuite() {
    assets_.reset();
    clips_.reset();
  }
  static std::unique_ptr<HumanAssets> assets_;
  static std::unique_ptr<std::vector<MotionClip>> clips_;
  static std::vector<std::string> categories_;
};
std::unique_ptr<HumanAssets> SynthPosePoolSharedData::assets_;
std::unique_ptr<std::vector<MotionClip>> SynthPosePoolSharedData::clips_;
std::vector<std::string> SynthPosePoolSharedData::categories_;

TEST_F(SynthPosePoolSharedData, GridSelectionEqualsThePlainScanOnMocap) {
  const HumanAssets& a = *assets_;
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  std::vector<JointSet> joints;
  for (const MotionClip& c : *clips_)
    for (size_t k = 0; k < c.frames.size(); ++k) joints.push_back(aligned_joints(a, rest, retarget_frame(a, rest, c, k)));
  const std::vector<size_t> fast = furthest_neighbour_selection(joints, 0.05);
  EXPECT_EQ(fast, furthest_neighbour_selection_reference(joints, 0.05));
  EXPECT_GT(fast.size(), 100u);
  EXPECT_LT(fast.size(), joints.size());
}

TEST_F(SynthPosePoolSharedData, MirrorSwapsSidesAndTwiceIsIdentity) {
  const HumanAssets& a = *assets_;
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  const BodyPose p = retarget_frame(a, rest, (*clips_)[1], 40);
  const BodyPose m = mirror_pose(a, p), mm = mirror_pose(a, m);
  for (size_t b = 0; b < p.bone_world.size(); ++b)
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(mm.bone_world[b].m[i], p.bone_world[b].m[i], 1e-12);
  const JointSet jp = aligned_joints(a, rest, p), jm = aligned_joints(a, rest, m);
  for (int j = 0; j < dp::tools::kJointCount; ++j) {
    const Vec3 want = jp[dp::tools::kJointMirror[j]];
    // The MakeHuman base mesh is symmetric to a few millimetres.
    EXPECT_NEAR(jm[j].x, -want.x, 0.01) << j;
    EXPECT_NEAR(jm[j].y, want.y, 0.01) << j;
    EXPECT_NEAR(jm[j].z, want.z, 0.01) << j;
  }
}

// Mirror images, `noise_copies` noise copies per pose and 0.5 recombinations per pose.
PoseVariation varied(int noise_copies, uint64_t seed) {
  PoseVariation v;
  v.mirror = true;
  v.noise_copies = noise_copies;
  v.recombined_per_pose = 0.5;
  v.seed = seed;
  return v;
}

TEST_F(SynthPosePoolSharedData, VariedPoolIsDeterministicStaysNearItsSourcesAndReportsEveryPose) {
  const HumanAssets& a = *assets_;
  PoseVariation v = varied(2, 7);
  PosePoolReport report;
  const PoseLibrary all = build_pose_pool(a, *clips_, categories_, v, 0.0, &report);
  size_t real = 0;
  for (const MotionClip& c : *clips_) real += c.frames.size();
  EXPECT_EQ(report.generated[0], real);
  EXPECT_EQ(report.generated[1], real);
  EXPECT_EQ(report.generated[2] + report.noise_dropped, 2 * real);
  EXPECT_GE(report.noise_rejected, 8 * report.noise_dropped);
  EXPECT_EQ(report.generated[3], size_t(std::llround(0.5 * double(real))));
  EXPECT_EQ(all.poses.size(), report.generated[0] + report.generated[1] + report.generated[2] + report.generated[3]);
  size_t sampled = 0;
  for (const auto& c : report.categories) sampled += c.sampled;
  EXPECT_EQ(sampled, real);

  // Same seed, same pool; another seed, other noise.
  const PoseLibrary again = build_pose_pool(a, *clips_, categories_, v, 0.0);
  ASSERT_EQ(again.origin, all.origin);
  for (size_t i = 0; i < all.poses.size(); i += 97)
    for (size_t b = 0; b < all.poses[i].bone_world.size(); ++b)
      ASSERT_EQ(again.poses[i].bone_world[b].m, all.poses[i].bone_world[b].m);
  v.seed = 8;
  const PoseLibrary other = build_pose_pool(a, *clips_, categories_, v, 0.0);
  EXPECT_NE(other.origin, all.origin);

  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  const int thigh = a.bone_index("LeftUpLeg"), shin = a.bone_index("LeftLeg");
  size_t noise_seen = 0, recombined_seen = 0;
  for (size_t i = 2 * real; i < all.poses.size(); ++i) {
    const std::string& o = all.origin[i];
    const size_t sp = o.find(' ');
    const size_t plus = o.find('+');
    if (o.find(" noise ") != std::string::npos) {
      const size_t src = size_t(std::find(all.origin.begin(), all.origin.begin() + long(real), o.substr(0, sp)) -
                                all.origin.begin());
      ASSERT_LT(src, real) << o;
      const BodyPose& n = all.poses[i];
      const BodyPose& s = all.poses[src];
      // Small: no joint moves more than 25 cm (hands at the end of four perturbed bones).
      const JointSet jn = aligned_joints(a, rest, n), js = aligned_joints(a, rest, s);
      EXPECT_LT(pose_distance(jn, js), 0.25) << o;
      // The knee stays a hinge: the shin keeps its angle to the knee's axis.
      const Vec3 dir = (rest.tails[shin] - rest.heads[shin]).normalized();
      auto off_axis = [&](const BodyPose& p) { return (p.bone_world[shin] * dir).dot(p.bone_world[shin] * Vec3{1, 0, 0}); };
      EXPECT_NEAR(off_axis(n), off_axis(s), 1e-9) << o;
      (void)thigh;
      ++noise_seen;
    } else if (plus != std::string::npos) {
      const size_t ia = size_t(std::find(all.origin.begin(), all.origin.begin() + long(real), o.substr(0, plus)) -
                               all.origin.begin());
      const size_t ib = size_t(std::find(all.origin.begin(), all.origin.begin() + long(real), o.substr(plus + 1)) -
                               all.origin.begin());
      ASSERT_LT(ia, real) << o;
      ASSERT_LT(ib, real) << o;
      const JointSet jc = aligned_joints(a, rest, all.poses[i]), ja = aligned_joints(a, rest, all.poses[ia]),
                     jb = aligned_joints(a, rest, all.poses[ib]);
      for (int j : {10, 11, 12, 13, 14, 15}) {  // knees, ankles, feet: from the lower-body source
        EXPECT_NEAR(jc[j].x, ja[j].x, 1e-9);
        EXPECT_NEAR(jc[j].y, ja[j].y, 1e-9);
      }
      // The upper body moves rigidly with its hips: head-to-hand distances as in its source.
      for (int j : {6, 7, 8, 9}) EXPECT_NEAR((jc[j] - jc[0]).norm(), (jb[j] - jb[0]).norm(), 1e-9);
      ++recombined_seen;
    }
  }
  EXPECT_GT(noise_seen, real);
  EXPECT_EQ(recombined_seen, report.generated[3]);

  // Pruned: the report's kept counts add up to the library.
  PosePoolReport pruned;
  v.seed = 7;
  const PoseLibrary lib = build_pose_pool(a, *clips_, categories_, v, 0.05, &pruned);
  size_t kept = 0, kept_real = 0, pooled = 0, pooled_kept = 0;
  for (size_t k = 0; k < 4; ++k) kept += pruned.kept[k];
  for (const auto& c : pruned.categories) {
    kept_real += c.kept;
    pooled += c.pooled;
    pooled_kept += c.pooled_kept;
    EXPECT_LE(c.kept, c.pooled_kept) << c.name;
    EXPECT_LE(c.pooled_kept, c.pooled) << c.name;
  }
  EXPECT_EQ(kept, lib.poses.size());
  EXPECT_EQ(kept_real, pruned.kept[0]);
  EXPECT_EQ(pooled, lib.candidate_count);  // every pose of every kind counts in one category
  EXPECT_EQ(pooled_kept, lib.poses.size());
  EXPECT_LT(lib.poses.size(), all.poses.size());
  EXPECT_GT(pruned.kept[2], 0u);  // noise copies add poses the clips lack
  EXPECT_GT(pruned.kept[3], 0u);
}

void expect_same_library(const PoseLibrary& want, const PoseLibrary& got) {
  ASSERT_EQ(got.origin, want.origin);
  ASSERT_EQ(got.candidate_count, want.candidate_count);
  ASSERT_EQ(got.poses.size(), want.poses.size());
  for (size_t i = 0; i < want.poses.size(); ++i) {
    ASSERT_EQ(got.poses[i].bone_world.size(), want.poses[i].bone_world.size());
    for (size_t b = 0; b < want.poses[i].bone_world.size(); ++b)
      ASSERT_EQ(std::memcmp(got.poses[i].bone_world[b].m.data(), want.poses[i].bone_world[b].m.data(), 9 * sizeof(double)), 0)
          << want.origin[i] << " bone " << b;
  }
}

TEST_F(SynthPosePoolSharedData, PoolFromTheCacheEqualsTheFreshPoolAndOtherInputsAreRefused) {
  const HumanAssets& a = *assets_;
  const std::string dir = fs::temp_directory_path() / ("synth_pose_cache_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = dir + "/pool.bin";
  std::vector<ClipEntry> entries = selected_clip_entries(kAssets, {"02_01", "60_01", "105_13"});
  const std::string key = pose_cache_key(kAssets, entries, 8);
  std::vector<std::string> names;
  for (const MotionClip& c : *clips_) names.push_back(c.name);
  const RealPoses fresh = retarget_pool(a, *clips_, categories_);
  ASSERT_GT(fresh.poses.size(), 500u);

  RealPoses got;
  std::vector<std::string> got_names;
  std::string why;
  EXPECT_FALSE(read_pose_cache(path, key, a.bones.size(), &got, &got_names, &why));
  EXPECT_NE(why.find("no such file"), std::string::npos) << why;
  write_pose_cache(path, key, fresh, names);
  ASSERT_TRUE(read_pose_cache(path, key, a.bones.size(), &got, &got_names, &why)) << why;
  EXPECT_EQ(got_names, names);
  EXPECT_EQ(got.category_of_clip, fresh.category_of_clip);
  ASSERT_EQ(got.categories.size(), fresh.categories.size());
  for (size_t c = 0; c < got.categories.size(); ++c) {
    EXPECT_EQ(got.categories[c].name, fresh.categories[c].name);
    EXPECT_EQ(got.categories[c].sampled, fresh.categories[c].sampled);
    EXPECT_EQ(got.categories[c].source_frames, fresh.categories[c].source_frames);
  }
  // The pruned, varied pool (what frames draw from) is the same bit for bit.
  const PoseVariation v = varied(1, 11);
  PosePoolReport from_cache_report;
  expect_same_library(build_pose_pool(a, fresh, v, 0.05), build_pose_pool(a, got, v, 0.05, &from_cache_report));
  EXPECT_EQ(from_cache_report.categories.size(), fresh.categories.size());

  // Another stride, another clip file stamp: refused, naming the first differing key line.
  EXPECT_FALSE(read_pose_cache(path, pose_cache_key(kAssets, entries, 4), a.bones.size(), &got, &got_names, &why));
  EXPECT_NE(why.find("made for other inputs"), std::string::npos) << why;
  EXPECT_NE(why.find("frame stride 4"), std::string::npos) << why;
  entries.pop_back();
  EXPECT_FALSE(read_pose_cache(path, pose_cache_key(kAssets, entries, 8), a.bones.size(), &got, &got_names, &why));
  EXPECT_NE(why.find("made for other inputs"), std::string::npos) << why;
  // A rig of another size, a flipped payload byte, a truncated file, another file: refused.
  EXPECT_FALSE(read_pose_cache(path, key, a.bones.size() + 1, &got, &got_names, &why));
  EXPECT_NE(why.find("bones"), std::string::npos) << why;
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  auto write = [&](const std::string& b) { std::ofstream(path, std::ios::binary) << b; };
  std::string damaged = bytes;
  damaged[damaged.size() / 2] ^= 0x10;
  write(damaged);
  EXPECT_FALSE(read_pose_cache(path, key, a.bones.size(), &got, &got_names, &why));
  EXPECT_NE(why.find("CRC-32"), std::string::npos) << why;
  write(bytes.substr(0, bytes.size() - 100));
  EXPECT_FALSE(read_pose_cache(path, key, a.bones.size(), &got, &got_names, &why));
  EXPECT_NE(why.find("truncated"), std::string::npos) << why;
  write("frames.jsonl is not a cache");
  EXPECT_FALSE(read_pose_cache(path, key, a.bones.size(), &got, &got_names, &why));
  EXPECT_NE(why.find("not a depthpose pose cache"), std::string::npos) << why;
  EXPECT_NE(why.find(path), std::string::npos) << why;
  fs::remove_all(dir);
}

TEST(SynthPoseSheetSharedData, OneRowPerSkeletonNaming) {
  // Per process: `make test` runs the normal and the ASan+UBSan binaries side by side.
  const std::string dir = fs::temp_directory_path() / ("synth_pose_sheet_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string sheet = dir + "/sheet.png";
  ASSERT_EQ(dp::testsupport::run_cli({"synth", "--assets", kAssets, "--clips", "02_01,60_01,16_01", "--pose-stride",
                                      "16", "--pose-sheet", sheet}),
            0);
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  ASSERT_NE(png_image_begin_read_from_file(&png, sheet.c_str()), 0) << sheet;
  png.format = PNG_FORMAT_RGB;
  dp::tools::ImageRgb img;
  img.resize(int(png.width), int(png.height));
  ASSERT_NE(png_image_finish_read(&png, nullptr, img.pixels.data(), 0, nullptr), 0) << sheet;
  EXPECT_EQ(img.width, 8 * 160);
  EXPECT_EQ(img.height, 3 * 240);  // cmu-asf, daz, cmu-asf-names
  // Every cell holds a body (non-white pixels).
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 8; ++col) {
      int body = 0;
      for (int y = 0; y < 240; ++y)
        for (int x = 0; x < 160; ++x) {
          const uint8_t* p = &img.pixels[(size_t(row * 240 + y) * img.width + size_t(col * 160 + x)) * 3];
          body += !(p[0] == 255 && p[1] == 255 && p[2] == 255);
        }
      EXPECT_GT(body, 1500) << row << " " << col;
    }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dp::synth
