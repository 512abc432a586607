// The runtime core against answers known analytically.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "runtime/cycle_counter.h"
#include "runtime/debug_check.h"
#include "runtime/depthpose.h"
#include "runtime/fixed_point.h"
#include "runtime/vote_selection.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using dp::tools::SyntheticFrame;

namespace {

struct Loaded {
  std::vector<uint8_t> bytes;
  blob::LoadedBlob view;
  std::unique_ptr<uint8_t, decltype(&std::free)> arena{nullptr, &std::free};
  size_t arena_bytes = 0;
  Pipeline pipeline;

  explicit Loaded(const blob::BlobContents& c, int max_w = 320, int max_h = 240) {
    bytes = blob::write_blob(c);
    EXPECT_EQ(blob::load_blob(bytes.data(), bytes.size(), &view), blob::BlobStatus::kOk);
    arena_bytes = required_arena_bytes(view, max_w, max_h);
    arena.reset(static_cast<uint8_t*>(std::aligned_alloc(64, (arena_bytes + 63) / 64 * 64)));
    EXPECT_EQ(pipeline.init(view, max_w, max_h, arena.get(), arena_bytes), Status::kOk);
  }
};

// Mean 3D position of the nonzero pixels of a frame.
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

}  // namespace

TEST(FixedPoint, ScaleAndRoundingRule) {
  EXPECT_EQ(scale_q13(1000, 1000), 8192);                 // 1 m, reference focal: scale 1.0
  EXPECT_EQ(scale_q13(1000, 2000), 4096);                 // 2 m: half
  EXPECT_EQ(scale_q13(1000, 100), kScaleMaxQ13);          // saturates below focal_factor / 4
  EXPECT_EQ(scale_q13(1000, 3000), (1000 * 8192 + 1500) / 3000);
  EXPECT_EQ(probe_offset_px(3, 4096), 2);                 // 1.5 rounds half up
  EXPECT_EQ(probe_offset_px(-3, 4096), -1);               // −1.5 rounds up to −1
  EXPECT_EQ(probe_offset_px(-5, 4096), -2);               // −2.5 → −2
  EXPECT_EQ(focal_factor_mm(262.5f, 525.0f), 500);
  EXPECT_EQ(focal_factor_mm(525.0f, 525.0f), 1000);
}

TEST(FixedPoint, FeatureOnTiltedPlaneHasKnownValue) {
  // z = 1500 + 2·(u − cx) mm along u (cx = 159.5, so use integer columns relative to 160).
  SyntheticFrame f = tools::make_plane_frame(320, 240, 1501.0f, 2.0f, 0.0f);
  const int u = 160, v = 120;
  const int32_t z = f.depth_mm[v * 320 + u];
  ASSERT_EQ(z, 1502);
  const int32_t focal = 1000;
  const int32_t s = scale_q13(focal, z);
  const int16_t du = 90;
  const int32_t off = probe_offset_px(du, s);
  ASSERT_EQ(off, int32_t(std::floor(90.0 * 8192.0 * 1000.0 / 1502.0 / 8192.0 + 0.5)));
  EXPECT_EQ(depth_feature(f.depth_mm.data(), 320, 240, u, v, z, focal, du, 0, 0, 0), 2 * off);
  EXPECT_EQ(depth_feature(f.depth_mm.data(), 320, 240, u, v, z, focal, -du, 0, du, 0), -4 * off);
  // Off-image probe reads the background constant.
  EXPECT_EQ(depth_feature(f.depth_mm.data(), 320, 240, u, v, z, focal, 4000, 0, 0, 0), kBackgroundDepthMm - z);
}

TEST(Pipeline, BpcDiscGivesOneProposalAtCentroidPushedBack) {
  Loaded L(tools::single_part_bpc(4, 2, 3, 55));
  SyntheticFrame f = tools::make_disc_frame(320, 240, 200.0f, 90.0f, 7.0f, 2000);
  FrameResult r;
  ASSERT_EQ(L.pipeline.process(f.view(), &r), Status::kOk);
  double cx, cy, cz;
  centroid(f, &cx, &cy, &cz);
  ASSERT_EQ(r.joint_count, 3);
  for (int j = 0; j < 3; ++j) {
    ASSERT_EQ(r.proposal_count[j], 1) << "joint " << j;
    EXPECT_NEAR(r.proposals[j][0].x_m, cx, 0.003);
    EXPECT_NEAR(r.proposals[j][0].y_m, cy, 0.003);
    EXPECT_NEAR(r.proposals[j][0].z_m, cz + 0.055, 0.001);
    // Every pixel votes with p = 1 and weight z² = 4.
    EXPECT_NEAR(r.proposals[j][0].confidence, 4.0 * r.evaluated_pixels, 1e-2);
  }
  EXPECT_EQ(r.flags & kFlagPixelsStrided, 0u);
}

TEST(Pipeline, OjrProposalIsCentroidPlusOffset) {
  Loaded L(tools::single_vote_ojr(2, 100, -50, 120));
  SyntheticFrame f = tools::make_disc_frame(320, 240, 120.0f, 150.0f, 6.0f, 1500);
  FrameResult r;
  ASSERT_EQ(L.pipeline.process(f.view(), &r), Status::kOk);
  double cx, cy, cz;
  centroid(f, &cx, &cy, &cz);
  for (int j = 0; j < 2; ++j) {
    ASSERT_GE(r.proposal_count[j], 1);
    EXPECT_NEAR(r.proposals[j][0].x_m, cx + 0.100, 0.003);
    EXPECT_NEAR(r.proposals[j][0].y_m, cy - 0.050, 0.003);
    EXPECT_NEAR(r.proposals[j][0].z_m, cz + 0.120, 0.001);
  }
}

TEST(Pipeline, MeanShiftSeparatesTwoClustersWithTheirConfidences) {
  auto c = tools::single_part_bpc(4, 1, 1, 0);
  c.config.max_votes_per_joint = 1024;
  c.config.max_starts_per_joint = 64;
  Loaded L(c);
  // Two small discs far apart (> 3 bandwidths) at different depths and sizes.
  SyntheticFrame f = tools::make_disc_frame(320, 240, 60.0f, 60.0f, 5.0f, 1000);
  SyntheticFrame g = tools::make_disc_frame(320, 240, 250.0f, 180.0f, 8.0f, 3000);
  int n1 = 0, n2 = 0;
  for (size_t i = 0; i < f.depth_mm.size(); ++i) {
    n1 += f.depth_mm[i] != 0;
    n2 += g.depth_mm[i] != 0;
    if (g.depth_mm[i]) f.depth_mm[i] = g.depth_mm[i];
  }
  FrameResult r;
  ASSERT_EQ(L.pipeline.process(f.view(), &r), Status::kOk);
  ASSERT_EQ(r.proposal_count[0], 2);
  // Confidence = Σ p·z²: n1·1² and n2·3²; the far disc (n2·9) wins.
  EXPECT_NEAR(r.proposals[0][0].confidence, 9.0 * n2, 1e-2 * n2);
  EXPECT_NEAR(r.proposals[0][1].confidence, 1.0 * n1, 1e-2 * n1);
  EXPECT_NEAR(r.proposals[0][0].z_m, 3.0, 0.002);
  EXPECT_NEAR(r.proposals[0][1].z_m, 1.0, 0.002);
}

TEST(Pipeline, RefusesFramesBeyondItsSizeAndBadArenas) {
  auto c = tools::single_part_bpc(4, 2, 1, 0);
  Loaded L(c, 160, 120);
  SyntheticFrame f = tools::make_disc_frame(320, 240, 100.0f, 100.0f, 5.0f, 2000);
  FrameResult r;
  EXPECT_EQ(L.pipeline.process(f.view(), &r), Status::kFrameTooLarge);
  EXPECT_EQ(r.proposal_count[0], 0);
  Pipeline p;
  EXPECT_EQ(p.process(f.view(), &r), Status::kNotInitialized);
  EXPECT_EQ(p.init(L.view, 160, 120, L.arena.get(), minimum_arena_bytes(L.view, 160, 120) - 64), Status::kArenaTooSmall);
  EXPECT_EQ(p.init(L.view, 160, 120, L.arena.get() + 8, L.arena_bytes - 64), Status::kArenaMisaligned);
  EXPECT_EQ(p.init(L.view, 0, 120, L.arena.get(), L.arena_bytes), Status::kBadArgument);
  DepthFrame bad = f.view();
  bad.stride_px = 10;
  EXPECT_EQ(L.pipeline.process(bad, &r), Status::kBadArgument);
  EXPECT_GE(L.arena_bytes, L.pipeline.arena_used_bytes());
}

// The blob stores split flags and split nodes only; init derives the traversal tables (a 16-byte
// SplitNode and a leaf record per node) into the arena. Every pixel's leaf in every tree, in every
// kernel, is the leaf the feature rule reaches walking the blob's own tables (expand_tree_tables),
// and a BPC arena has no optional part (minimum = required).
TEST(Pipeline, DerivesTheForestTablesAtInitForEveryKernel) {
  const blob::BlobContents c = tools::random_sparse_bpc_forest(31, 3, 14, 6, 300, 300, 800, 3000);
  Loaded L(c, 160, 120);
  const blob::LoadedBlob& b = L.view;
  EXPECT_EQ(minimum_arena_bytes(b, 160, 120), L.arena_bytes);
  EXPECT_GE(L.arena_bytes, b.total_nodes * 20) << "16-byte split nodes and a 4-byte record per node";
  std::vector<blob::TreeNode> nodes(b.total_nodes);
  std::vector<uint32_t> left(b.total_nodes), record(b.total_nodes);
  blob::expand_tree_tables(b, nodes.data(), left.data(), record.data());
  int checked = 0;
  for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kAvx2, KernelIsa::kAvx512, KernelIsa::kNeon}) {
    if (!kernel_isa_supported(isa)) continue;
    ASSERT_EQ(L.pipeline.set_kernel(isa), Status::kOk);
    for (int i = 0; i < 2; ++i) {
      const SyntheticFrame f = tools::make_disc_frame(160, 120, 60.0f + 25 * i, 55.0f, 30.0f, uint16_t(1500 + 400 * i));
      FrameResult r;
      ASSERT_EQ(L.pipeline.process(f.view(), &r), Status::kOk);
      ASSERT_GT(L.pipeline.evaluated_pixel_count(), 100);
      auto depth_at = [&](int32_t u, int32_t v) -> int32_t {
        if (u < 0 || v < 0 || u >= f.width || v >= f.height) return kBackgroundDepthMm;
        const uint16_t z = f.depth_mm[size_t(v) * f.width + u];
        return z == 0 ? kBackgroundDepthMm : z;
      };
      const int32_t focal = focal_factor_mm(f.intrinsics.fx, b.meta->reference_focal_px);
      for (int32_t p = 0; p < L.pipeline.evaluated_pixel_count(); p += 7) {
        const EvaluatedPixel px = L.pipeline.evaluated_pixels()[p];
        const int32_t s = scale_q13(focal, px.z_mm);
        for (int t = 0; t < b.tree_count(); ++t, ++checked) {
          const size_t first = b.tree_first[t];
          uint32_t m = 1;
          for (int level = 0; level < b.depth(); ++level) {
            const blob::TreeNode& n = nodes[first + m - 1];
            const int32_t d1 = depth_at(px.u + probe_offset_px(n.du1, s), px.v + probe_offset_px(n.dv1, s));
            const int32_t d2 = depth_at(px.u + probe_offset_px(n.du2, s), px.v + probe_offset_px(n.dv2, s));
            m = left[first + m - 1] + (d1 - d2 > n.threshold_mm ? 1u : 0u);
          }
          ASSERT_EQ(left[first + m - 1], m) << "the walk ends on a leaf node";
          ASSERT_EQ(L.pipeline.leaf_of(p, t), record[first + m - 1]) << kernel_isa_name(isa) << " pixel " << p << " tree " << t;
        }
      }
    }
  }
  EXPECT_GT(checked, 500);
}

TEST(Pipeline, BudgetStridesPixelsAndFlagsIt) {
  auto c = tools::single_part_bpc(4, 2, 1, 0);
  c.config.max_evaluated_pixels = 500;
  c.config.max_votes_per_joint = 100;
  Loaded L(c);
  SyntheticFrame f = tools::make_disc_frame(320, 240, 160.0f, 120.0f, 40.0f, 2500);
  FrameResult r;
  ASSERT_EQ(L.pipeline.process(f.view(), &r), Status::kOk);
  EXPECT_GT(r.foreground_pixels, 500);
  EXPECT_LE(r.evaluated_pixels, 500);
  EXPECT_GT(r.pixel_stride, 1);
  EXPECT_NE(r.flags & kFlagPixelsStrided, 0u);
  EXPECT_NE(r.flags & kFlagVotesTruncated, 0u);
  EXPECT_GT(r.stage_cycles[kStageForest], 0u);
  // The config cannot ask for more pixels than the arena was sized for.
  blob::RuntimeConfig more = L.pipeline.config();
  more.max_evaluated_pixels = 100000;
  EXPECT_EQ(L.pipeline.set_config(more), Status::kBadConfig);
}

TEST(Pipeline, EmptyFrameReportsNoForeground) {
  Loaded L(tools::single_part_bpc(4, 2, 1, 0));
  SyntheticFrame f = tools::make_disc_frame(320, 240, 100.0f, 100.0f, 0.0f, 0);
  FrameResult r;
  ASSERT_EQ(L.pipeline.process(f.view(), &r), Status::kOk);
  EXPECT_NE(r.flags & kFlagNoForeground, 0u);
  EXPECT_EQ(r.proposal_count[0], 0);
}

TEST(Pipeline, ForestFollowsTheFeatureRule) {
  // A depth-1 tree splitting on a unary feature: probe 40 px·m to the right; a pixel whose probe
  // leaves the disc reads background (far) → feature > threshold → right leaf (part 1).
  blob::BlobContents c = tools::single_part_bpc(2, 0, 1, 0);
  const blob::TreeNode leaf{0, 0, 0, 0, blob::kPadThreshold};
  c.tree_nodes[0] = {blob::TreeNode{40, 0, 0, 0, 100}, leaf, leaf};  // root split, leaf nodes 2 and 3
  c.tree_left_child[0] = {2, 2, 3};
  c.tree_leaf_index[0] = {0, 0, 1};
  c.bpc_leaves = {32768, 0, 0, 32768};
  Loaded L(c);
  SyntheticFrame f = tools::make_disc_frame(320, 240, 160.0f, 120.0f, 20.0f, 1000);
  FrameResult r;
  ASSERT_EQ(L.pipeline.process(f.view(), &r), Status::kOk);
  int checked = 0;
  for (int i = 0; i < L.pipeline.evaluated_pixel_count(); ++i) {
    const EvaluatedPixel p = L.pipeline.evaluated_pixels()[i];
    const int32_t off = probe_offset_px(40, scale_q13(focal_factor_mm(262.5f, 525.0f), p.z_mm));
    const int pu = p.u + off;
    const bool outside = pu >= 320 || f.depth_mm[p.v * 320 + pu] == 0;
    uint16_t dist[2];
    L.pipeline.part_distribution(i, dist);
    EXPECT_EQ(dist[1] == 32768, outside) << "pixel " << p.u << "," << p.v;
    ++checked;
  }
  EXPECT_GT(checked, 1000);
}

// ---- contracts: conversions of user values, ownership, debug checks, the counter -------------

TEST(FixedPoint, FocalFactorIsDefinedForEveryFloat) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(focal_factor_mm(inf, 525.0f), kMaxFocalFactor);
  EXPECT_EQ(focal_factor_mm(1e30f, 525.0f), kMaxFocalFactor);
  EXPECT_EQ(focal_factor_mm(std::numeric_limits<float>::max(), 525.0f), kMaxFocalFactor);
  EXPECT_EQ(focal_factor_mm(34000.0f, 525.0f), 64762);            // 64761.9 < limit: rounds, no clamp
  EXPECT_EQ(focal_factor_mm(34500.0f, 525.0f), kMaxFocalFactor);  // 65714 ≥ limit: clamped
  EXPECT_EQ(focal_factor_mm(nan, 525.0f), 1);
  EXPECT_EQ(focal_factor_mm(525.0f, nan), 1);
  EXPECT_EQ(focal_factor_mm(-inf, 525.0f), 1);
  EXPECT_EQ(focal_factor_mm(-300.0f, 525.0f), 1);
  EXPECT_EQ(focal_factor_mm(0.0f, 525.0f), 1);
  EXPECT_EQ(focal_factor_mm(525.0f, 0.0f), kMaxFocalFactor);  // +inf ratio
  EXPECT_EQ(focal_factor_mm(0.2f, 525.0f), 1);                // 0.38: below one unit
  EXPECT_EQ(focal_factor_mm(0.8f, 525.0f), 2);                // 1.52 rounds to 2
}

TEST(Pipeline, RefusesNonFiniteIntrinsicsAndAcceptsHugeFiniteOnes) {
  Loaded l(tools::single_part_bpc(4, 2, 3, 55));
  const SyntheticFrame f = tools::make_disc_frame(320, 240, 160.0f, 120.0f, 50.0f, 2000);
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  FrameResult r;
  for (float bad : {inf, -inf, nan, 0.0f, -525.0f}) {
    for (int field = 0; field < 4; ++field) {
      if ((field >= 2) && !(bad != bad || bad == inf || bad == -inf)) continue;  // any finite cx, cy is fine
      DepthFrame d = f.view();
      float* fields[4] = {&d.intrinsics.fx, &d.intrinsics.fy, &d.intrinsics.cx, &d.intrinsics.cy};
      *fields[field] = bad;
      EXPECT_EQ(l.pipeline.process(d, &r), Status::kBadArgument) << "field " << field << " = " << bad;
      EXPECT_EQ(r.evaluated_pixels, 0);
      uint8_t mask[1] = {1};
      d.foreground_mask = mask;
      EXPECT_EQ(l.pipeline.process_user(d, 1, &r), Status::kBadArgument) << "field " << field;
      const EvaluatedPixel px{10, 10, 2000, 0};
      const uint32_t leaf = 0;
      EXPECT_EQ(l.pipeline.aggregate_from_leaves(d.intrinsics, &px, &leaf, 1, &r), Status::kBadArgument);
    }
  }
  // Huge but finite focal lengths: the focal factor saturates (every probe lands on the border)
  // and the frame still runs.
  DepthFrame huge = f.view();
  huge.intrinsics.fx = huge.intrinsics.fy = 3e38f;  // (fx + fy) / 2 overflows to +inf inside
  ASSERT_EQ(l.pipeline.process(huge, &r), Status::kOk);
  EXPECT_GT(r.evaluated_pixels, 0);
}

static_assert(!std::is_copy_constructible_v<Pipeline>, "two copies would share one arena");
static_assert(!std::is_copy_assignable_v<Pipeline>, "two copies would share one arena");
static_assert(std::is_nothrow_move_constructible_v<Pipeline>, "a Pipeline can be handed over");
static_assert(std::is_nothrow_move_assignable_v<Pipeline>, "a Pipeline can be handed over");

TEST(Pipeline, MoveHandsTheArenaOverAndLeavesTheSourceUninitialised) {
  Loaded l(tools::single_part_bpc(4, 2, 3, 55));
  const SyntheticFrame f = tools::make_disc_frame(320, 240, 160.0f, 120.0f, 50.0f, 2000);
  FrameResult before, after;
  ASSERT_EQ(l.pipeline.process(f.view(), &before), Status::kOk);
  ASSERT_GT(before.proposal_count[0], 0);
  Pipeline moved(std::move(l.pipeline));
  EXPECT_EQ(l.pipeline.process(f.view(), &after), Status::kNotInitialized);
  EXPECT_EQ(l.pipeline.arena_used_bytes(), 0u);
  EXPECT_EQ(moved.arena_used_bytes(), l.arena_bytes);
  ASSERT_EQ(moved.process(f.view(), &after), Status::kOk);
  EXPECT_EQ(after.proposal_count[0], before.proposal_count[0]);
  EXPECT_EQ(0, std::memcmp(after.proposals[0], before.proposals[0], sizeof(JointProposal) * size_t(before.proposal_count[0])));
  Pipeline assigned;
  assigned = std::move(moved);
  EXPECT_EQ(moved.process(f.view(), &after), Status::kNotInitialized);
  ASSERT_EQ(assigned.process(f.view(), &after), Status::kOk);
  EXPECT_EQ(0, std::memcmp(after.proposals[0], before.proposals[0], sizeof(JointProposal) * size_t(before.proposal_count[0])));
}

#if DP_DEBUG_CHECKS
TEST(DebugChecks, AFailedPreconditionAbortsNamingIt) {
  int evaluated = 0;
  DP_DCHECK(++evaluated == 1);
  EXPECT_EQ(evaluated, 1);  // compiled in: the condition runs
  EXPECT_DEATH(DP_DCHECK(evaluated == 2), "debug check failed: evaluated == 2 at .*runtime_pipeline_test.cc");
  // A broken runtime precondition: a vote cut of a buffer that is not over its cap.
  Vote votes[4] = {};
  int32_t counts[blob::kMaxJoints] = {};
  uint32_t keys[2 * kVoteSlots];
  counts[0] = 2;
  const VoteSets sets{votes, counts, keys};
  EXPECT_DEATH(cut_votes(sets, 0, 3), "debug check failed: cap >= 1 && n > cap");
}
#else
TEST(DebugChecks, CompiledAwayInRelease) {
  int evaluated = 0;
  DP_DCHECK(++evaluated == 5);  // neither evaluated nor fatal
  EXPECT_EQ(evaluated, 0);
}
#endif

TEST(CycleCounter, CountsForwardInItsDocumentedUnit) {
  const uint64_t a = cycle_count();
  volatile uint64_t sink = 0;
  for (int i = 0; i < 100000; ++i) sink = sink + uint64_t(i);
  const uint64_t b = cycle_count();
  EXPECT_GT(b, a);
#if defined(__x86_64__)
  EXPECT_STREQ(cycle_counter_unit(), "tsc_cycles");
  EXPECT_EQ(cycle_counter_hz(), 0u);
#elif defined(__aarch64__)
  EXPECT_STREQ(cycle_counter_unit(), "cntvct_ticks");
  EXPECT_GT(cycle_counter_hz(), 1000000u);  // the generic timer runs at MHz rates
#endif
}
