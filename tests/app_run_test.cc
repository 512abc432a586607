// `depthpose run`: JSON schema per frame, proposals where the analytic answer says, overlays,
// summary counts, --every/--frames, bad inputs, and the CLI subcommands end to end.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "forest_blob/blob_writer.h"
#include "platform/oni_recorder.h"
#include "tests/app_run_support.h"
#include "tests/app_test_support.h"
#include "tests/shared_data.h"
#include "tools/app/overlay.h"
#include "tools/app/run.h"
#include "tools/app/skeleton_eval.h"
#include "tools/cli/command.h"
#include "tools/common/error.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using namespace dp::tools;
using dp::apptest::Captured;
using dp::apptest::TempDir;
using dp::apptest::run_captured;
using nlohmann::json;

// Counts the allocations made by the thread that asked for it (other threads, e.g. OpenNI2's, are
// not this test's business). Under AddressSanitizer its allocator hooks see every malloc and
// operator new; otherwise a replaced operator new sees the C++ allocations.
namespace {
thread_local bool t_count_news = false;
thread_local long t_news = 0;
}  // namespace
#if defined(__SANITIZE_ADDRESS__)
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, size_t),
                                                         void (*free_hook)(const volatile void*));
namespace {
void count_malloc(const volatile void*, size_t) {
  if (t_count_news) ++t_news;
}
void ignore_free(const volatile void*) {}
const int kHooksInstalled = __sanitizer_install_malloc_and_free_hooks(count_malloc, ignore_free);
}  // namespace
#else
__attribute__((noinline)) void* operator new(std::size_t n) {
  if (t_count_news) ++t_news;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
__attribute__((noinline)) void operator delete(void* p) noexcept { std::free(p); }
__attribute__((noinline)) void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#endif

namespace {

constexpr int16_t kPushBackMm = 55;
constexpr int kPart = 2;

// Blob: depth-1 BPC tree, every leaf all mass on part 2, 3 joints reading part 2.
std::string write_test_blob(const TempDir& dir) {
  const std::string path = dir / "test.blob";
  blob::BlobContents c = single_part_bpc(4, kPart, 3, kPushBackMm);
  c.joint_names = {"head", "neck", "hand_l"};
  blob::save_blob_file(path, blob::write_blob(c));
  return path;
}

// Mean camera-frame point of the nonzero pixels.
void centroid(const SyntheticFrame& f, double* x, double* y, double* z) {
  double sx = 0, sy = 0, sz = 0;
  int n = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const uint16_t d = f.depth_mm[size_t(v) * f.width + u];
      if (!d) continue;
      const double zm = d * 0.001;
      sx += (u - f.intrinsics.cx) * zm / f.intrinsics.fx;
      sy += -(v - f.intrinsics.cy) * zm / f.intrinsics.fy;
      sz += zm;
      ++n;
    }
  *x = sx / n;
  *y = sy / n;
  *z = sz / n;
}

// Reads an RGB PNG through libpng's simplified API.
std::vector<uint8_t> read_rgb_png(const std::string& path, int* w, int* h) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return {};
  image.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) return {};
  *w = int(image.width);
  *h = int(image.height);
  return pixels;
}

}  // namespace

TEST(AppRun, JsonLinePerFrameWithTheDocumentedSchema) {
  TempDir dir;
  const std::string blob = write_test_blob(dir);
  auto frames = apptest::write_disc_dataset(dir / "ds", 4);
  RunOptions o;
  o.blob_path = blob;
  o.source_spec = "dataset:" + (dir / "ds");
  o.json = true;
  o.all_proposals = true;
  Captured c = run_captured(o);
  ASSERT_EQ(c.lines.size(), 4u) << c.log;
  EXPECT_EQ(c.summary.frames_processed, 4);
  EXPECT_EQ(c.summary.frames_read, 4);
  EXPECT_EQ(c.summary.corrupt, 0);
  EXPECT_FALSE(c.summary.source_failed);
  EXPECT_GT(c.summary.max_ms, 0.0);
  EXPECT_LE(c.summary.p50_ms, c.summary.p99_ms);
  EXPECT_LE(c.summary.p99_ms, c.summary.max_ms + 1e-9);
  EXPECT_NE(c.log.find("summary: 4 frames processed"), std::string::npos) << c.log;
  for (size_t i = 0; i < c.lines.size(); ++i) {
    const json& j = c.lines[i];
    EXPECT_EQ(j.at("frame").get<int>(), int(i));
    EXPECT_EQ(j.at("source_index").get<int>(), int(i));
    EXPECT_EQ(j.at("timestamp_us").get<uint64_t>(), uint64_t(i) * 33333u);
    EXPECT_TRUE(j.at("frame_ms").is_number());
    EXPECT_TRUE(j.at("kernel").is_string());
    // The unit of the *_cycles fields is the build's platform counter.
#if defined(__x86_64__)
    EXPECT_EQ(j.at("counter_unit"), "tsc_cycles");
#elif defined(__aarch64__)
    EXPECT_EQ(j.at("counter_unit"), "cntvct_ticks");
#else
    EXPECT_EQ(j.at("counter_unit"), "ns");
#endif
    ASSERT_EQ(j.at("joints").size(), 3u);
    EXPECT_EQ(j["joints"][0].at("name"), "head");
    EXPECT_EQ(j["joints"][2].at("name"), "hand_l");
    double cx, cy, cz;
    centroid(frames[i], &cx, &cy, &cz);
    for (const json& joint : j["joints"]) {
      // All pixels vote for every joint: the best proposal is the disc's centroid pushed back.
      EXPECT_NEAR(joint.at("x").get<double>(), cx, 0.004);
      EXPECT_NEAR(joint.at("y").get<double>(), cy, 0.004);
      EXPECT_NEAR(joint.at("z").get<double>(), cz + kPushBackMm / 1000.0, 0.002);
      EXPECT_GT(joint.at("confidence").get<double>(), 0.0);
    }
    ASSERT_EQ(j.at("proposals").size(), 3u);
    ASSERT_GE(j["proposals"][0].size(), 1u);
    EXPECT_EQ(j["proposals"][0][0].size(), 4u);
    EXPECT_NEAR(j["proposals"][0][0][0].get<double>(), j["joints"][0]["x"].get<double>(), 1e-4);
    for (const char* stage : {"foreground", "forest", "votes", "mean_shift"})
      EXPECT_TRUE(j.at("stage_cycles").at(stage).is_number_unsigned()) << stage;
    EXPECT_TRUE(j.at("total_cycles").is_number_unsigned());
    EXPECT_TRUE(j.at("flags").is_array());
    EXPECT_TRUE(j.at("over_budget").is_boolean());
    EXPECT_GT(j.at("foreground_pixels").get<int>(), 80);
    EXPECT_GT(j.at("evaluated_pixels").get<int>(), 0);
    EXPECT_GE(j.at("pixel_stride").get<int>(), 1);
  }
}

TEST(AppRun, EveryFramesAndCorruptFramesAreCounted) {
  TempDir dir;
  const std::string blob = write_test_blob(dir);
  apptest::write_disc_dataset(dir / "ds", 7);
  // Frame 3 corrupt, frame 5 missing: skipped and counted, not fatal.
  { std::ofstream(dir / "ds/depth/000003.png") << "not a png"; }
  std::remove((dir / "ds/depth/000005.png").c_str());
  RunOptions o;
  o.blob_path = blob;
  o.source_spec = "dataset:" + (dir / "ds");
  o.json = true;
  o.every = 2;
  Captured c = run_captured(o);
  // Readable frames 0 1 2 4 6 → processed the 1st, 3rd, 5th of them.
  EXPECT_EQ(c.summary.frames_read, 5);
  EXPECT_EQ(c.summary.frames_processed, 3);
  EXPECT_EQ(c.summary.skipped_by_every, 2);
  EXPECT_EQ(c.summary.corrupt, 2);
  ASSERT_EQ(c.lines.size(), 3u);
  EXPECT_EQ(c.lines[0]["source_index"], 0);
  EXPECT_EQ(c.lines[1]["source_index"], 2);
  EXPECT_EQ(c.lines[2]["source_index"], 6);
  EXPECT_NE(c.log.find("000003.png"), std::string::npos) << c.log;
  EXPECT_NE(c.log.find("000005.png"), std::string::npos) << c.log;

  o.every = 1;
  o.max_frames = 2;
  Captured limited = run_captured(o);
  EXPECT_EQ(limited.lines.size(), 2u);
}

TEST(AppRun, OverlaysShowPartsJointsAndAreWritten) {
  TempDir dir;
  const std::string blob = write_test_blob(dir);
  auto frames = apptest::write_disc_dataset(dir / "ds", 2);
  RunOptions o;
  o.blob_path = blob;
  o.source_spec = "dataset:" + (dir / "ds");
  o.overlay_dir = dir / "overlay";
  Captured c = run_captured(o);
  // Without --json: one text line per frame naming every joint.
  ASSERT_EQ(c.text.size(), 2u);
  EXPECT_EQ(c.text[1].rfind("frame 1 (source 1,", 0), 0u) << c.text[1];
  for (const char* name : {" head ", " neck ", " hand_l "}) EXPECT_NE(c.text[0].find(name), std::string::npos) << c.text[0];
  ASSERT_EQ(c.summary.frames_processed, 2);
  for (int i = 0; i < 2; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/%06d.png", i);
    int w = 0, h = 0;
    std::vector<uint8_t> rgb = read_rgb_png(o.overlay_dir + name, &w, &h);
    ASSERT_EQ(w, 160) << name;
    ASSERT_EQ(h, 120);
    const SyntheticFrame& f = frames[size_t(i)];
    uint8_t part[3];
    part_colour(kPart, part);
    // A disc pixel away from the joint dots has the part colour; background stays black.
    const int u = 50 + 7 * i + 5, v = 40 + 3 * i;
    ASSERT_NE(f.depth_mm[size_t(v) * 160 + u], 0);
    const uint8_t* p = &rgb[(size_t(v) * 160 + u) * 3];
    EXPECT_EQ(p[0], part[0]);
    EXPECT_EQ(p[1], part[1]);
    EXPECT_EQ(p[2], part[2]);
    const uint8_t* bg = &rgb[(size_t(110) * 160 + 150) * 3];
    EXPECT_EQ(bg[0] + bg[1] + bg[2], 0);
    // The joints sit at the disc centroid: a red dot there.
    double cx, cy, cz;
    centroid(f, &cx, &cy, &cz);
    float ju, jv;
    ASSERT_TRUE(project(f.intrinsics, float(cx), float(cy), float(cz + 0.055), &ju, &jv));
    const uint8_t* dot = &rgb[(size_t(std::lround(jv)) * 160 + size_t(std::lround(ju))) * 3];
    EXPECT_EQ(dot[0], 255);
    EXPECT_EQ(dot[1], 40);
  }
}

TEST(AppRunSharedData, RunsOnSkeltrackRawFrames) {
  TempDir dir;
  const std::string blob = write_test_blob(dir);
  RunOptions o;
  o.blob_path = blob;
  o.source_spec = "raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:640x480";
  o.json = true;
  o.max_frames = 3;
  Captured c = run_captured(o);
  ASSERT_EQ(c.lines.size(), 3u) << "needs " << dp::test::shared_path("data/skeltrack-frames") << " (12 files): " << c.log;
  EXPECT_NE(c.log.find("640x480, fx 525.0 fy 525.0 cx 319.5 cy 239.5"), std::string::npos) << c.log;
  for (const json& j : c.lines) EXPECT_GT(j["foreground_pixels"].get<int>(), 1000);
}

TEST(AppRunSharedData, TheFrameLoopAllocatesNothing) {
  TempDir dir;
  const std::string blob = write_test_blob(dir);
  RunOptions o;
  o.blob_path = blob;
  o.source_spec = "raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:640x480";
  o.json = true;
  o.all_proposals = true;
  long news_in_loop = -1;
  // Count from after frame 2 (stdio buffers exist by then) to after frame 12, the last.
  o.on_frame = [&](int64_t processed) {
    if (processed == 2) {
      t_news = 0;
      t_count_news = true;
    } else if (processed == 12) {
      t_count_news = false;
      news_in_loop = t_news;
    }
  };
  Captured c = run_captured(o);
  t_count_news = false;
  ASSERT_EQ(c.summary.frames_processed, 12) << c.log;
  EXPECT_EQ(news_in_loop, 0) << "frames 3..12 (read, process, JSON) must not allocate";
  // With segmentation (segmenter, per-user votes and mean shift, users in the JSON) as well.
  o.segment = SegmentMode::kOn;
  news_in_loop = -1;
  Captured s = run_captured(o);
  t_count_news = false;
  ASSERT_EQ(s.summary.frames_processed, 12) << s.log;
  ASSERT_TRUE(s.summary.segmented);
  ASSERT_TRUE(s.lines[11].contains("users"));
  EXPECT_EQ(news_in_loop, 0) << "frames 3..12 with segmentation must not allocate";
  // With the skeleton tracker (the shipped blob has its 16 joints): per-user skeletons in the JSON.
  o.blob_path = "models/ojr.blob";
  news_in_loop = -1;
  Captured k = run_captured(o);
  t_count_news = false;
  ASSERT_EQ(k.summary.frames_processed, 12) << k.log;
  ASSERT_TRUE(k.lines[11]["skeleton"].get<bool>()) << k.log;
  ASSERT_FALSE(k.lines[11]["users"].empty());
  EXPECT_TRUE(k.lines[11]["users"][0]["joints"][0].contains("state"));
  EXPECT_TRUE(k.lines[11]["users"][0]["joints"][1]["orientation"].is_null()) << "the neck ends no bone";
  EXPECT_GT(k.lines[11]["stage_cycles"]["skeleton"].get<uint64_t>(), 0u);
  EXPECT_EQ(news_in_loop, 0) << "frames 3..12 with segmentation and the skeleton tracker must not allocate";
}

TEST(AppRun, ReplaysARecordingMadeByRecord) {
  TempDir dir;
  const std::string blob = write_test_blob(dir);
  apptest::write_disc_dataset(dir / "ds", 3);
  RunOptions direct;
  direct.blob_path = blob;
  direct.source_spec = "dataset:" + (dir / "ds");
  direct.json = true;
  direct.segment = SegmentMode::kOff;  // same processing for both sources (auto differs)
  Captured a = run_captured(direct);
  const std::string spec = direct.source_spec;
  platform::record_oni([&] { return platform::open_source(spec); }, true, dir / "x.oni", {});
  RunOptions replay = direct;
  replay.source_spec = "oni:" + (dir / "x.oni");
  Captured b = run_captured(replay);
  ASSERT_EQ(a.lines.size(), 3u);
  ASSERT_EQ(b.lines.size(), 3u);
  for (size_t i = 0; i < 3; ++i)
    for (size_t j = 0; j < 3; ++j) {
      // Same depth and focal length (written as field of view) → the same joints.
      EXPECT_NEAR(a.lines[i]["joints"][j]["x"].get<double>(), b.lines[i]["joints"][j]["x"].get<double>(), 1e-3);
      EXPECT_NEAR(a.lines[i]["joints"][j]["z"].get<double>(), b.lines[i]["joints"][j]["z"].get<double>(), 1e-4);
    }
}

TEST(AppRunSharedData, BadInputsGiveOneLineErrors) {
  TempDir dir;
  const std::string blob = write_test_blob(dir);
  auto error_of = [](const RunOptions& o) {
    try {
      FILE* null_out = std::fopen("/dev/null", "w");
      run_app(o, null_out, null_out);
      std::fclose(null_out);
    } catch (const ToolError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  RunOptions o;
  o.blob_path = dir / "missing.blob";
  o.source_spec = "raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:640x480";
  EXPECT_NE(error_of(o).find("missing.blob"), std::string::npos);
  { std::ofstream(dir / "junk.blob") << "junk junk junk junk junk junk junk junk junk junk junk junk"; }
  o.blob_path = dir / "junk.blob";
  EXPECT_NE(error_of(o).find("junk.blob"), std::string::npos);
  o.blob_path = blob;
  o.source_spec = "raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:320x240";
  EXPECT_NE(error_of(o).find("wrong resolution"), std::string::npos) << error_of(o);
  o.source_spec = "raw:" + (dir / "*.nothing") + ":640x480";
  EXPECT_NE(error_of(o).find("no file matches"), std::string::npos);
  o.source_spec = "raw:frames:64zx48";
  EXPECT_NE(error_of(o).find("bad frame size"), std::string::npos);
  o.source_spec = "kinect:0";
  EXPECT_NE(error_of(o).find("unknown source"), std::string::npos);
  o.source_spec = "dataset:" + (dir / "nodataset");
  EXPECT_NE(error_of(o).find("nodataset"), std::string::npos);
  o.source_spec = "v4l2:/dev/video-does-not-exist";
  EXPECT_NE(error_of(o).find("no such device"), std::string::npos) << error_of(o);
  for (const RunOptions* p : {&o}) EXPECT_EQ(error_of(*p).find('\n'), std::string::npos);
}

TEST(AppCli, SubcommandsAreRegisteredWithHelp) {
  for (const char* name : {"run", "record", "devices", "skeleton-eval", "reid-eval"}) {
    const cli::Command* c = cli::find_command(name);
    ASSERT_NE(c, nullptr) << name;
    char arg0[16], help[] = "--help";
    std::snprintf(arg0, sizeof arg0, "%s", name);
    char* argv[] = {arg0, help};
    testing::internal::CaptureStdout();
    EXPECT_EQ(c->run(2, argv), 0);
    std::string out = testing::internal::GetCapturedStdout();
    EXPECT_NE(out.find(std::string("depthpose ") + name), std::string::npos) << out;
  }
}

namespace {
// The joints of a body facing the camera (−z) 2.5 m away, its left at +x, 0.2 m either side of
// the mid-plane, one joint 0.1 m below the other.
std::array<Position, kSkeletonJoints> body_facing_the_camera() {
  std::array<Position, kSkeletonJoints> truth{};
  for (int j = 0; j < kSkeletonJoints; ++j) {
    const double side = j >= kShoulderL ? ((j - kShoulderL) % 2 == 0 ? 1.0 : -1.0) : 0.0;
    truth[size_t(j)] = {side * 0.2, 0.8 - 0.1 * j, 2.5};
  }
  return truth;
}
}  // namespace

// skeleton-eval --swap-causes: a tracker swap is classified by what the tracker took and by the
// state of the torso, the parent and the mirror joint around it.
TEST(SkeletonEvalSwapCause, ClassifiesChoiceFacingParentPairAndFirstProposal) {
  const std::array<Position, kSkeletonJoints> truth = body_facing_the_camera();
  Skeleton sk{};
  sk.facing_known = 1;
  sk.facing[2] = -1.0f;  // as the truth's
  std::array<Position, kSkeletonJoints> out = truth;
  std::array<bool, kSkeletonJoints> located{};
  located.fill(true);
  // The left wrist on the right wrist's place, its own second proposal; the right wrist 0.2 m
  // further right: not crossed. The first proposal was right.
  out[kWristL] = truth[kWristR];
  out[kWristR] = {truth[kWristR][0] - 0.2, truth[kWristR][1], truth[kWristR][2]};
  sk.joints[kWristL].proposal = 1;
  sk.joints[kWristL].proposal_joint = kWristL;
  SwapCause c = swap_cause(kWristL, sk, out, located, truth, true, truth[kWristL]);
  EXPECT_EQ(c.choice, SwapChoice::kOwnOther);
  EXPECT_FALSE(c.facing_crossed);
  EXPECT_FALSE(c.parent_swapped);
  EXPECT_FALSE(c.pair_crossed);
  EXPECT_TRUE(c.first_right);
  // The right wrist on the left one's place, left of the left wrist: crossed; the tracker faced
  // away, the left elbow is swapped too, the first proposal was elsewhere.
  out[kWristR] = {truth[kWristL][0] + 0.05, truth[kWristL][1], truth[kWristL][2]};
  out[kElbowL] = truth[kElbowR];
  sk.facing[2] = 1.0f;
  sk.joints[kWristL].proposal = 0;
  c = swap_cause(kWristL, sk, out, located, truth, true, truth[kWristR]);
  EXPECT_EQ(c.choice, SwapChoice::kOwnFirst);
  EXPECT_TRUE(c.facing_crossed);
  EXPECT_TRUE(c.parent_swapped);
  EXPECT_TRUE(c.pair_crossed);
  EXPECT_FALSE(c.first_right);
  sk.joints[kWristL].proposal_joint = kWristR;
  EXPECT_EQ(swap_cause(kWristL, sk, out, located, truth, false, truth[kWristL]).choice, SwapChoice::kMirrorProposal);
  EXPECT_FALSE(swap_cause(kWristL, sk, out, located, truth, false, truth[kWristL]).first_right);
  sk.joints[kWristL].proposal = -1;
  EXPECT_EQ(swap_cause(kWristL, sk, out, located, truth, false, truth[kWristL]).choice, SwapChoice::kPrediction);
  sk.facing_known = 0;
  EXPECT_FALSE(swap_cause(kWristL, sk, out, located, truth, false, truth[kWristL]).facing_crossed);
}

// skeleton-eval's per-frame figures: a crossed pair counts as crossed for both of its joints,
// the left one too (whose mirror joint comes after it in the joint order).
TEST(SkeletonEvalFrameFigures, ACrossedPairCountsForTheLeftAndTheRightJoint) {
  const std::array<Position, kSkeletonJoints> truth = body_facing_the_camera();
  Skeleton sk{};
  sk.facing_known = 1;
  sk.facing[2] = -1.0f;
  auto proposals = std::make_unique<FrameResult>();
  proposals->joint_count = kSkeletonJoints;
  for (int j = 0; j < kSkeletonJoints; ++j) {
    // Every joint tracked at its truth, its first proposal there too; the wrists exchanged.
    const int at = j == kWristL ? kWristR : j == kWristR ? kWristL : j;
    TrackedJoint& t = sk.joints[j];
    t.x_m = float(truth[size_t(at)][0]);
    t.y_m = float(truth[size_t(at)][1]);
    t.z_m = float(truth[size_t(at)][2]);
    t.state = JointState::kTracked;
    t.confidence = 0.5f;
    t.evidence = 5;
    t.proposal = 0;
    t.proposal_joint = j;
    proposals->proposal_count[j] = 1;
    proposals->proposals[j][0] = {t.x_m, t.y_m, t.z_m, 1.0f};
  }
  SkeletonEvalReport rep;
  std::array<bool, kSkeletonJoints> visible{};
  visible.fill(true);
  visible[kWristR] = false;  // hidden: its swap is counted among the hidden joints'
  add_frame_figures(sk, *proposals, truth, visible, &rep);
  EXPECT_EQ(rep.lr_joint_frames, 14);
  EXPECT_EQ(rep.tracker_swaps, 2);
  EXPECT_EQ(rep.proposal_swaps, 2);
  EXPECT_EQ(rep.lr_visible_joint_frames, 13);
  EXPECT_EQ(rep.tracker_swaps_visible, 1);
  EXPECT_EQ(rep.proposal_swaps_visible, 1);
  EXPECT_EQ(rep.tracker_swaps_by_joint[kWristL], 1);
  EXPECT_EQ(rep.tracker_swaps_by_joint[kWristR], 1);
  EXPECT_EQ(rep.tracker_swap_pair_crossed[kWristL], 1);
  EXPECT_EQ(rep.tracker_swap_pair_crossed[kWristR], 1);
  EXPECT_EQ(rep.tracker_swap_choice[kWristL][size_t(SwapChoice::kOwnFirst)], 1);
  EXPECT_EQ(rep.tracker_swap_first_right[kWristL], 0);
  EXPECT_EQ(rep.tracker_hits[kWristL], 0);
  EXPECT_EQ(rep.tracker_hits[kElbowL], 1);
}

// skeleton-eval's intervals resample whole sequences: identical sequences give a point, and the
// point values are those of the summed counts.
TEST(SkeletonEvalIntervals, ResampleWholeSequences) {
  // joint frames, first-proposal hits, tracker hits, first-proposal swaps, tracker swaps
  const SequenceFigures same{1000, 500, 520, 60, 30};
  const SequenceIntervals one = sequence_intervals({same, same, same, same}, 500, 7);
  EXPECT_NEAR(one.gain, 0.02, 1e-12);
  EXPECT_NEAR(one.swap_change, -0.5, 1e-12);
  EXPECT_NEAR(one.gain_low, 0.02, 1e-12);
  EXPECT_NEAR(one.gain_high, 0.02, 1e-12);
  EXPECT_NEAR(one.swap_change_low, -0.5, 1e-12);
  EXPECT_NEAR(one.swap_change_high, -0.5, 1e-12);

  // One sequence whose swaps all go, one that keeps them all: the point is their sum's change, the
  // interval spans it and stays within the two sequences' own changes (−1 and 0).
  std::vector<SequenceFigures> two = {{1000, 500, 540, 40, 0}, {1000, 500, 490, 60, 60}};
  const SequenceIntervals a = sequence_intervals(two, 2000, 1);
  EXPECT_NEAR(a.gain, 0.015, 1e-12);
  EXPECT_NEAR(a.swap_change, -0.4, 1e-12);
  EXPECT_LT(a.swap_change_low, a.swap_change);
  EXPECT_GT(a.swap_change_high, a.swap_change);
  EXPECT_GE(a.swap_change_low, -1.0);
  EXPECT_LE(a.swap_change_high, 0.0);
  EXPECT_LT(a.gain_low, a.gain);
  EXPECT_GT(a.gain_high, a.gain);
  // A fixed generator: the same counts and seed give the same intervals.
  const SequenceIntervals b = sequence_intervals(two, 2000, 1);
  EXPECT_EQ(a.swap_change_low, b.swap_change_low);
  EXPECT_EQ(a.gain_high, b.gain_high);
  EXPECT_EQ(sequence_intervals({}, 2000, 1).swap_change, 0.0);
}
