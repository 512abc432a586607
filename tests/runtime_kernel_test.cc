// Every kernel (the plain C++ reference; SSE4.1, AVX2, AVX-512 on x86-64; NEON on aarch64) and
// every node layout give the same leaf for every pixel and tree, the same votes and sums, and the
// pipeline the same proposals, on random forests and frames and on the real Skeltrack frames with
// PCL's trees. The same file runs on both architectures (natively, and under qemu-aarch64).
#include <gtest/gtest.h>

#include <set>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "runtime/depthpose.h"
#include "runtime/fixed_point.h"
#include "runtime/fast_math.h"
#include "runtime/kernels/foreground_kernel.h"
#include "runtime/kernels/forest_kernel.h"
#include "runtime/kernels/mean_shift_kernel.h"
#include "runtime/kernels/vote_kernel.h"
#include "runtime/mean_shift.h"
#include "runtime/kernels/dispatch.h"
#include "runtime/ojr_votes.h"
#include "tests/node_layouts.h"
#include "tests/shared_data.h"
#if !DP_NO_BZIP2
#include "tools/convert/pcl_import.h"
#endif
#include "tools/demo/fixtures.h"

using namespace dp;
using dp::tools::SyntheticFrame;

namespace {

#if defined(__aarch64__)
const KernelIsa kSimdIsas[] = {KernelIsa::kNeon};
#else
const KernelIsa kSimdIsas[] = {KernelIsa::kAvx2, KernelIsa::kAvx512};
#endif
const KernelIsa kAllIsas[] = {KernelIsa::kScalar, KernelIsa::kAvx2, KernelIsa::kAvx512, KernelIsa::kNeon};

struct Runner {
  std::vector<uint8_t> bytes;
  blob::LoadedBlob view{};
  std::unique_ptr<uint8_t, decltype(&std::free)> arena{nullptr, &std::free};
  Pipeline pipeline;

  Runner(std::vector<uint8_t> blob_bytes, int max_w, int max_h) : bytes(std::move(blob_bytes)) {
    EXPECT_EQ(blob::load_blob(bytes.data(), bytes.size(), &view), blob::BlobStatus::kOk);
    const size_t n = required_arena_bytes(view, max_w, max_h);
    arena.reset(static_cast<uint8_t*>(std::aligned_alloc(64, (n + 63) / 64 * 64)));
    EXPECT_EQ(pipeline.init(view, max_w, max_h, arena.get(), n), Status::kOk);
  }
};

struct Outcome {
  FrameResult result{};
  std::vector<uint32_t> leaves;  // [tree][pixel]
};

Outcome run(Runner& r, KernelIsa isa, const DepthFrame& frame) {
  Outcome o;
  EXPECT_EQ(r.pipeline.set_kernel(isa), Status::kOk);
  EXPECT_EQ(r.pipeline.process(frame, &o.result), Status::kOk);
  const int32_t n = r.pipeline.evaluated_pixel_count();
  for (int t = 0; t < r.view.tree_count(); ++t)
    for (int32_t i = 0; i < n; ++i) o.leaves.push_back(r.pipeline.leaf_of(i, t));
  return o;
}

// Same leaves, same proposals (bit for bit), same flags and counts.
void expect_identical(const Outcome& ref, const Outcome& simd, const char* what) {
  ASSERT_EQ(ref.leaves.size(), simd.leaves.size()) << what;
  size_t differing = 0;
  for (size_t i = 0; i < ref.leaves.size(); ++i) differing += ref.leaves[i] != simd.leaves[i];
  EXPECT_EQ(differing, 0u) << what << ": leaves differ for " << differing << " of " << ref.leaves.size();
  // Everything but the measured overrun (timing, not content) must agree.
  EXPECT_EQ(ref.result.flags & ~uint32_t(kFlagOverCycleBudget), simd.result.flags & ~uint32_t(kFlagOverCycleBudget))
      << what;
  EXPECT_EQ(ref.result.predicted_cycles, simd.result.predicted_cycles) << what;
  EXPECT_EQ(ref.result.evaluated_pixels, simd.result.evaluated_pixels) << what;
  for (int j = 0; j < ref.result.joint_count; ++j) {
    ASSERT_EQ(ref.result.proposal_count[j], simd.result.proposal_count[j]) << what << " joint " << j;
    EXPECT_EQ(0, std::memcmp(ref.result.proposals[j], simd.result.proposals[j],
                             sizeof(JointProposal) * size_t(ref.result.proposal_count[j])))
        << what << " joint " << j;
  }
}

void compare_all_kernels(Runner& r, const DepthFrame& frame, const std::string& what) {
  const Outcome ref = run(r, KernelIsa::kScalar, frame);
  ASSERT_GT(ref.leaves.size(), 0u) << what;
  for (KernelIsa isa : kSimdIsas) {
    if (!kernel_isa_supported(isa)) continue;  // reported by KernelDispatch.FollowsTheCpu
    expect_identical(ref, run(r, isa, frame), (what + " " + kernel_isa_name(isa)).c_str());
  }
}

// Random depth: a disc of noisy depth, holes, and near-saturating depths (scale clamps at 4.0).
SyntheticFrame noisy_frame(uint64_t seed, int w, int h) {
  std::mt19937_64 rng(seed);
  SyntheticFrame f = tools::make_disc_frame(w, h, w * 0.4f, h * 0.6f, h * 0.45f, 1000);
  std::uniform_int_distribution<int> depth(100, 6000), coin(0, 9);
  for (auto& d : f.depth_mm)
    if (d) d = coin(rng) == 0 ? 0 : uint16_t(coin(rng) == 1 ? 150 : depth(rng));
  f.intrinsics.fx = f.intrinsics.fy = 600.0f;  // not the reference focal: exercises focal_factor
  return f;
}

std::vector<uint16_t> read_skeltrack(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<uint16_t> depth(640 * 480);
  in.read(reinterpret_cast<char*>(depth.data()), std::streamsize(depth.size() * 2));
  EXPECT_TRUE(in.good()) << path << ": missing or short (expected 640x480 uint16 from the shared data: DEPTHPOSE_SHARED)";
  return depth;
}

using testing_support::TreeCopies;
const kernels::NodeLayout kLayouts[] = {kernels::NodeLayout::kBlob10, kernels::NodeLayout::kPacked8,
                                        kernels::NodeLayout::kWide16, kernels::NodeLayout::kSplit};
const char* layout_name(kernels::NodeLayout l) {
  switch (l) {
    case kernels::NodeLayout::kBlob10: return "blob 10B";
    case kernels::NodeLayout::kPacked8: return "packed 8B";
    case kernels::NodeLayout::kWide16: return "16B";
    case kernels::NodeLayout::kSplit: return "split";
  }
  return "?";
}
// The ISA's trees kernel over `layout`: evaluate_trees for the layouts the pipeline passes (split,
// packed or blob nodes, chosen by the arguments), evaluate_trees_study for 16-byte nodes.
void run_trees(KernelIsa isa, kernels::NodeLayout layout, const kernels::ForestKernelArgs* a, int trees) {
  if (layout != kernels::NodeLayout::kWide16 || isa == KernelIsa::kScalar) return kernels::forest_trees_kernel(isa)(a, trees);
#if defined(__aarch64__)
  return kernels::neon::evaluate_trees_study(a, trees, layout);
#else
  if (isa == KernelIsa::kAvx2) return kernels::avx2::evaluate_trees_study(a, trees, layout);
  return kernels::avx512::evaluate_trees_study(a, trees, layout);
#endif
}

}  // namespace

#if defined(__aarch64__)
TEST(KernelDispatch, ThisMachineHasNeon) {
  // NEON is part of AArch64: kBest is the NEON kernels; the x86 ISAs are not in this build.
  EXPECT_TRUE(kernel_isa_supported(KernelIsa::kNeon));
  EXPECT_FALSE(kernel_isa_supported(KernelIsa::kAvx2));
  EXPECT_FALSE(kernel_isa_supported(KernelIsa::kAvx512));
  EXPECT_EQ(best_forest_kernel_isa(), KernelIsa::kNeon);
  EXPECT_EQ(widest_kernel_isa(), KernelIsa::kNeon);
  EXPECT_EQ(kernels::forest_trees_kernel(KernelIsa::kBest), kernels::forest_trees_kernel(KernelIsa::kNeon));
  EXPECT_NE(kernels::forest_kernel(KernelIsa::kNeon), kernels::forest_kernel(KernelIsa::kScalar));
  EXPECT_EQ(kernels::bpc_scan_kernel(KernelIsa::kBest), kernels::bpc_scan_kernel(KernelIsa::kNeon));
  EXPECT_EQ(kernels::mean_shift_sums_kernel(KernelIsa::kBest), kernels::mean_shift_sums_kernel(KernelIsa::kNeon));
  EXPECT_STREQ(kernel_isa_name(KernelIsa::kNeon), "neon");
  Pipeline p;
  EXPECT_EQ(p.forest_kernel(), KernelIsa::kScalar);  // before init
}
#else
TEST(KernelDispatch, FollowsTheCpu) {
  // What the dispatcher offers must follow the CPU, read here through GCC's own CPU model (an
  // independent check of the runtime's CPUID/XGETBV reading): AVX2 kernels with AVX2+BMI1+BMI2,
  // AVX-512 kernels with AVX-512 F/DQ/BW/VL. kBest is the AVX2 forest kernel (faster on split
  // nodes) and the widest vote and mean-shift kernels. CPUs lacking an ISA are named in the output:
  // that ISA's kernels cannot be checked on them.
  __builtin_cpu_init();
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
  const bool avx512 = avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                      __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl");
  if (!avx512) std::printf("note: this CPU has no AVX-512: the AVX-512 kernels are not exercised here\n");
  if (!avx2) std::printf("note: this CPU has no AVX2: the AVX2 kernels are not exercised here\n");
  EXPECT_FALSE(kernel_isa_supported(KernelIsa::kNeon));
  EXPECT_EQ(kernel_isa_supported(KernelIsa::kAvx2), avx2);
  EXPECT_EQ(kernel_isa_supported(KernelIsa::kAvx512), avx512);
  const KernelIsa best_forest = avx2 ? KernelIsa::kAvx2 : KernelIsa::kScalar;
  const KernelIsa widest = avx512 ? KernelIsa::kAvx512 : best_forest;
  EXPECT_EQ(best_forest_kernel_isa(), best_forest);
  EXPECT_EQ(widest_kernel_isa(), widest);
  EXPECT_EQ(kernels::forest_kernel(KernelIsa::kBest), kernels::forest_kernel(best_forest));
  EXPECT_EQ(kernels::forest_trees_kernel(KernelIsa::kBest), kernels::forest_trees_kernel(best_forest));
  if (avx2) {
    EXPECT_NE(kernels::forest_kernel(KernelIsa::kAvx2), kernels::forest_kernel(KernelIsa::kScalar));
  }
  EXPECT_EQ(kernels::bpc_scan_kernel(KernelIsa::kBest), kernels::bpc_scan_kernel(widest));
  EXPECT_EQ(kernels::mean_shift_sums_kernel(KernelIsa::kBest), kernels::mean_shift_sums_kernel(widest));
  Pipeline p;
  EXPECT_EQ(p.forest_kernel(), KernelIsa::kScalar);  // before init
}
#endif

TEST(KernelPacking, PackedNodeRoundTrips) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> off(-kernels::kPackedMaxOffset, kernels::kPackedMaxOffset), thr(-32768, 32767);
  for (int i = 0; i < 10000; ++i) {
    blob::TreeNode n{int16_t(off(rng)), int16_t(off(rng)), int16_t(off(rng)), int16_t(off(rng)), int16_t(thr(rng))};
    const uint64_t bits = kernels::pack_node(n).bits;
    const int16_t offsets[4] = {n.du1, n.dv1, n.du2, n.dv2};
    int32_t t = 0;
    for (int k = 0; k < 4; ++k) {
      const int16_t lane = int16_t(uint16_t(bits >> (16 * k)));
      EXPECT_EQ((lane & ~15) >> 2, offsets[k] * 4);
      t |= (lane & 15) << (4 * k);
    }
    EXPECT_EQ(int16_t(uint16_t(t)), n.threshold_mm);
  }
}

TEST(KernelExactness, RandomForestsRandomFramesBothLayouts) {
  struct Case { uint64_t seed; int trees, depth, max_offset, thresh; };
  // max_offset 4096 (the format's limit) uses the blob's 10-byte nodes; ≤ 2047 the packed nodes.
  const Case cases[] = {{1, 3, 12, 4096, 3000}, {2, 2, 9, 300, 200}, {3, 1, 16, 2047, 32767}, {4, 3, 1, 50, 10}};
  for (const Case& c : cases) {
    Runner r(blob::write_blob(tools::random_bpc_forest(c.seed, c.trees, c.depth, 8, c.max_offset, c.thresh)), 320,
             240);
    const std::string what = "forest seed " + std::to_string(c.seed);
    compare_all_kernels(r, tools::make_disc_frame(320, 240, 150.0f, 100.0f, 60.0f, 2100).view(), what + " disc");
    compare_all_kernels(r, tools::make_plane_frame(320, 240, 1800.0f, 3.0f, -2.0f).view(), what + " plane");
    for (uint64_t s = 0; s < 3; ++s)
      compare_all_kernels(r, noisy_frame(100 * c.seed + s, 320, 240).view(), what + " noisy " + std::to_string(s));
    // A small frame inside the 320x240 arena: the padded stride follows the frame, not the maximum.
    compare_all_kernels(r, noisy_frame(9, 97, 31).view(), what + " 97x31");
  }
}

// The kernels' inputs for a frame, made the pipeline's way: the padded probe image (background
// border, background where there is no reading) and every pixel with a reading.
static void kernel_input(const SyntheticFrame& f, std::vector<uint16_t>* probe, std::vector<EvaluatedPixel>* pixels) {
  probe->assign(kernels::padded_probe_elements(f.width, f.height), 0);
  kernels::fill_probe_border(probe->data(), f.width, f.height);
  pixels->clear();
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const uint16_t z = f.depth_mm[size_t(v) * f.width + u];
      (*probe)[size_t(v + 1) * (f.width + 2) + u + 1] = kernels::probe_element(z);
      if (z) pixels->push_back(EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0});
    }
}

TEST(KernelExactness, KernelsAgreeOnEveryLayoutDirectly) {
  // Calls the kernels without the pipeline: every node layout (kernels::NodeLayout), every kernel.
  const blob::BlobContents c = tools::random_bpc_forest(11, 1, 14, 8, 1500, 400);
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  const SyntheticFrame f = noisy_frame(5, 200, 150);
  std::vector<uint16_t> probe;
  std::vector<EvaluatedPixel> pixels;
  kernel_input(f, &probe, &pixels);
  const TreeCopies copies(b);
  const int32_t n = int32_t(pixels.size());
  auto evaluate = [&](KernelIsa isa, kernels::NodeLayout layout) {
    std::vector<uint32_t> out(pixels.size(), 0xFFFFFFFFu);
    const kernels::ForestKernelArgs a = copies.args(0, layout, probe.data(), f.width, f.height,
                                                    focal_factor_mm(600.0f, 525.0f), pixels.data(), n, out.data());
    run_trees(isa, layout, &a, 1);
    return out;
  };
  const std::vector<uint32_t> ref = evaluate(KernelIsa::kScalar, kernels::NodeLayout::kBlob10);
  int compared = 0;
  for (KernelIsa isa : kSimdIsas)
    for (kernels::NodeLayout layout : kLayouts) {
      if (!kernel_isa_supported(isa)) continue;
      EXPECT_EQ(evaluate(isa, layout), ref) << kernel_isa_name(isa) << " " << layout_name(layout);
      ++compared;
    }
  int supported = 0;
  for (KernelIsa isa : kSimdIsas) supported += kernel_isa_supported(isa);
  EXPECT_GE(supported, 1) << "no SIMD kernel on this machine: the comparison would be vacuous";
  EXPECT_EQ(compared, 4 * supported);
}

TEST(KernelExactness, EveryPixelCountAndEveryImageEdge) {
  // The AVX-512 kernel steps 8 pixels at a time (padding the last step with copies) and clamps
  // probes as unsigned, sending probes off the left or top edge to the far border: every count
  // 1..19 and pixels on all four edges and corners, with offsets that leave the image on every side.
  const blob::BlobContents c = tools::random_bpc_forest(13, 2, 12, 8, 40, 400);  // probes land just off the edges
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  SyntheticFrame f = noisy_frame(21, 64, 48);
  std::mt19937_64 rng(22);
  std::uniform_int_distribution<int> depth(400, 4000);
  for (auto& d : f.depth_mm) d = uint16_t(depth(rng));  // readings up to every edge
  std::vector<uint16_t> probe;
  std::vector<EvaluatedPixel> all;
  kernel_input(f, &probe, &all);
  std::vector<EvaluatedPixel> edge;
  for (const EvaluatedPixel& p : all)
    if (p.u == 0 || p.v == 0 || p.u == f.width - 1 || p.v == f.height - 1) edge.push_back(p);
  ASSERT_GE(edge.size(), 19u);
  const TreeCopies copies(b);
  for (int32_t n = 1; n <= 19; ++n) {
    std::vector<EvaluatedPixel> pixels(edge.begin(), edge.begin() + n);
    pixels[0] = EvaluatedPixel{0, 0, 700, 0};  // a near corner pixel: large probe offsets
    if (n > 1) pixels[1] = EvaluatedPixel{uint16_t(f.width - 1), uint16_t(f.height - 1), 650, 0};
    auto run = [&](KernelIsa isa, kernels::NodeLayout layout) {
      std::vector<std::vector<uint32_t>> out(2, std::vector<uint32_t>(size_t(n), 0xFFFFFFFFu));
      kernels::ForestKernelArgs a[2];
      for (int t = 0; t < 2; ++t)
        a[t] = copies.args(t, layout, probe.data(), f.width, f.height, focal_factor_mm(525.0f, 525.0f), pixels.data(),
                           n, out[size_t(t)].data());
      run_trees(isa, layout, a, 2);
      return out;
    };
    const auto ref = run(KernelIsa::kScalar, kernels::NodeLayout::kBlob10);
    for (KernelIsa isa : kSimdIsas)
      for (kernels::NodeLayout layout : kLayouts) {
        if (!kernel_isa_supported(isa)) continue;
        EXPECT_EQ(run(isa, layout), ref) << kernel_isa_name(isa) << " " << layout_name(layout) << " pixels " << n;
      }
  }
}

TEST(KernelProbeImage, ElementsCarryTheBiasAndTheBackground) {
  // The SIMD kernels' child bit is exact only when every element has bit 15 set (forest_kernel.h).
  EXPECT_EQ(kernels::probe_element(0), 0xFFFF);  // no reading: background
  EXPECT_EQ(kernels::probe_element(kBackgroundDepthMm), 0xFFFF);
  EXPECT_EQ(kernels::probe_element(40000), 0xFFFF);  // beyond the representable depths: background
  EXPECT_EQ(kernels::probe_element(1), 0x8001);
  for (uint16_t z = 1; z < kBackgroundDepthMm; z = uint16_t(z * 3 + 1)) {
    EXPECT_EQ(kernels::probe_depth_of(kernels::probe_element(z)), z);
    EXPECT_NE(kernels::probe_element(z) & kernels::kProbeBias, 0);
  }
  EXPECT_EQ(kernels::probe_depth_of(kernels::probe_element(32766)), 32766);
  std::vector<uint16_t> padded(kernels::padded_probe_elements(3, 2), 0);
  kernels::fill_probe_border(padded.data(), 3, 2);
  for (size_t i = 0; i < padded.size(); ++i) {
    const bool interior = i / 5 >= 1 && i / 5 <= 2 && i % 5 >= 1 && i % 5 <= 3;
    EXPECT_EQ(padded[i], interior ? 0 : 0xFFFF) << "element " << i;
  }
}

TEST(KernelExactness, ExtremeThresholdsAndDepths) {
  // The unsigned compare t + e2 <u e1 relies on t ≥ −32768 and 1 ≤ depth ≤ 32767: thresholds at both
  // int16 ends and depths from 1 mm to the largest foreground depth, the background and holes.
  blob::BlobContents c = tools::random_bpc_forest(17, 2, 11, 8, 300, 400);
  std::mt19937_64 rng(18);
  const int16_t extremes[] = {-32768, -32767, -32766, -16384, -1, 0, 1, 16384, 32765, 32766, 32767};
  std::uniform_int_distribution<int> pick(0, int(sizeof extremes / sizeof extremes[0]) - 1), any(-32768, 32767),
      coin(0, 3);
  for (size_t t = 0; t < c.tree_nodes.size(); ++t)
    for (size_t m = 1; m <= c.tree_nodes[t].size(); ++m)
      if (c.tree_left_child[t][m - 1] != m)  // split nodes (a leaf node keeps its pad threshold)
        c.tree_nodes[t][m - 1].threshold_mm = coin(rng) ? extremes[pick(rng)] : int16_t(any(rng));
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  SyntheticFrame f = noisy_frame(19, 80, 60);
  const uint16_t depths[] = {0, 1, 2, 3, 150, 1000, 4000, 32765, 32766, kBackgroundDepthMm};
  std::uniform_int_distribution<int> which(0, int(sizeof depths / sizeof depths[0]) - 1);
  for (auto& d : f.depth_mm) d = depths[which(rng)];
  std::vector<uint16_t> probe;
  std::vector<EvaluatedPixel> listed, pixels;
  kernel_input(f, &probe, &listed);
  for (const EvaluatedPixel& p : listed)
    if (p.z_mm < kBackgroundDepthMm) pixels.push_back(p);  // what the pipeline lists
  ASSERT_GT(pixels.size(), 1000u);
  const TreeCopies copies(b);
  const int32_t n = int32_t(pixels.size());
  auto run = [&](KernelIsa isa, kernels::NodeLayout layout) {
    std::vector<std::vector<uint32_t>> out(2, std::vector<uint32_t>(pixels.size(), 0xFFFFFFFFu));
    kernels::ForestKernelArgs a[2];
    for (int t = 0; t < 2; ++t)
      a[t] = copies.args(t, layout, probe.data(), f.width, f.height, focal_factor_mm(525.0f, 525.0f), pixels.data(), n,
                         out[size_t(t)].data());
    run_trees(isa, layout, a, 2);
    return out;
  };
  const auto ref = run(KernelIsa::kScalar, kernels::NodeLayout::kBlob10);
  // The reference itself against the feature rule written out (fixed_point.h), per pixel and tree.
  for (int t = 0; t < 2; ++t)
    for (int32_t i = 0; i < n; i += 97) {
      const EvaluatedPixel p = pixels[size_t(i)];
      const int32_t s = scale_q13(focal_factor_mm(525.0f, 525.0f), p.z_mm);
      uint32_t node = 1;  // 1-based
      for (int level = 0; level < b.depth(); ++level) {
        const blob::TreeNode& nd = copies.tree_nodes(t)[node - 1];
        auto depth_at = [&](int32_t u, int32_t v) -> int32_t {
          if (u < 0 || v < 0 || u >= f.width || v >= f.height) return kBackgroundDepthMm;
          const uint16_t z = f.depth_mm[size_t(v) * f.width + u];
          return z == 0 || z >= kBackgroundDepthMm ? kBackgroundDepthMm : z;
        };
        const int32_t d1 = depth_at(p.u + probe_offset_px(nd.du1, s), p.v + probe_offset_px(nd.dv1, s));
        const int32_t d2 = depth_at(p.u + probe_offset_px(nd.du2, s), p.v + probe_offset_px(nd.dv2, s));
        node = copies.tree_left_child(t)[node - 1] + (d1 - d2 > nd.threshold_mm ? 1u : 0u);
      }
      ASSERT_EQ(copies.tree_left_child(t)[node - 1], node) << "a walk of depth steps ends on a leaf node";
      EXPECT_EQ(ref[size_t(t)][size_t(i)], copies.tree_leaf_index(t)[node - 1]) << "pixel " << i;
    }
  for (KernelIsa isa : kSimdIsas)
    for (kernels::NodeLayout layout : kLayouts) {
      if (!kernel_isa_supported(isa)) continue;
      EXPECT_EQ(run(isa, layout), ref) << kernel_isa_name(isa) << " " << layout_name(layout);
    }
}

TEST(KernelExactness, DeepUnbalancedSparseTrees) {
  // Depth-20 sparse trees, unbalanced (a spine to level 20, other nodes split at 85 %), in every
  // kernel and layout: leaves reached above level 20 stay on their leaf node.
  const blob::BlobContents c = tools::random_sparse_bpc_forest(23, 3, 20, 8, 600, 300, 850, 40000);
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  ASSERT_EQ(b.depth(), 20);
  const SyntheticFrame f = noisy_frame(24, 160, 120);
  std::vector<uint16_t> probe;
  std::vector<EvaluatedPixel> pixels;
  kernel_input(f, &probe, &pixels);
  ASSERT_GT(pixels.size(), 2u * 2048u);
  const TreeCopies copies(b);
  const int32_t n = int32_t(pixels.size());
  auto run = [&](KernelIsa isa, kernels::NodeLayout layout) {
    std::vector<std::vector<uint32_t>> out(3, std::vector<uint32_t>(pixels.size(), 0xFFFFFFFFu));
    kernels::ForestKernelArgs a[3];
    for (int t = 0; t < 3; ++t)
      a[t] = copies.args(t, layout, probe.data(), f.width, f.height, focal_factor_mm(400.0f, 525.0f), pixels.data(), n,
                         out[size_t(t)].data());
    run_trees(isa, layout, a, 3);
    return out;
  };
  const auto ref = run(KernelIsa::kScalar, kernels::NodeLayout::kBlob10);
  // Leaf levels (breadth-first: a child's level is its parent's + 1): the pixels must reach many
  // leaves, some at the bottom and some above it.
  std::vector<int> level(b.tree_node_count(0) + 1, 0);
  for (uint32_t m = 1; m <= b.tree_node_count(0); ++m)
    if (copies.tree_left_child(0)[m - 1] != m) level[copies.tree_left_child(0)[m - 1]] = level[copies.tree_left_child(0)[m - 1] + 1] = level[m] + 1;
  std::vector<uint32_t> record_node(b.meta->leaf_count, 0);
  for (uint32_t m = 1; m <= b.tree_node_count(0); ++m)
    if (copies.tree_left_child(0)[m - 1] == m) record_node[copies.tree_leaf_index(0)[m - 1]] = m;
  std::set<uint32_t> distinct(ref[0].begin(), ref[0].end());
  int deepest = 0, shallowest = 99;
  for (uint32_t r : distinct) {
    deepest = std::max(deepest, level[record_node[r]]);
    shallowest = std::min(shallowest, level[record_node[r]]);
  }
  EXPECT_GT(distinct.size(), 50u) << "the pixels must spread over many leaves for the comparison to mean much";
  EXPECT_GE(deepest, 14);
  EXPECT_LT(shallowest, 14);
  for (KernelIsa isa : kSimdIsas)
    for (kernels::NodeLayout layout : kLayouts) {
      if (!kernel_isa_supported(isa)) continue;
      EXPECT_EQ(run(isa, layout), ref) << kernel_isa_name(isa) << " " << layout_name(layout);
    }
}

TEST(KernelExactness, AllTreesInOneCallEqualOneCallPerTree) {
  // evaluate_trees shares each chunk's setup between trees; every tree's leaves must still equal the
  // reference's, whatever the layout of each tree and across chunk boundaries (> 2048 pixels).
  const blob::BlobContents c = tools::random_bpc_forest(12, 3, 13, 8, 1500, 400);
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  const SyntheticFrame f = noisy_frame(8, 160, 120);
  std::vector<uint16_t> probe;
  std::vector<EvaluatedPixel> pixels;
  kernel_input(f, &probe, &pixels);
  pixels.pop_back();  // an odd count: the last chunk gets a padding pixel
  ASSERT_GT(pixels.size(), 2u * 2048u);
  const TreeCopies copies(b);
  const int32_t n = int32_t(pixels.size());
  std::vector<std::vector<uint32_t>> ref(3, std::vector<uint32_t>(pixels.size()));
  using L = kernels::NodeLayout;
  auto args = [&](int t, L layout, uint32_t* out) {
    return copies.args(t, layout, probe.data(), f.width, f.height, focal_factor_mm(300.0f, 525.0f), pixels.data(), n, out);
  };
  for (int t = 0; t < 3; ++t) kernels::forest_kernel(KernelIsa::kScalar)(args(t, L::kBlob10, ref[size_t(t)].data()));
  // Per tree: all blob nodes, tree 1 packed, all packed, all split, and one of each.
  const L mixes[5][3] = {{L::kBlob10, L::kBlob10, L::kBlob10}, {L::kBlob10, L::kPacked8, L::kBlob10},
                         {L::kPacked8, L::kPacked8, L::kPacked8}, {L::kSplit, L::kSplit, L::kSplit},
                         {L::kSplit, L::kPacked8, L::kBlob10}};
  for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kAvx2, KernelIsa::kAvx512, KernelIsa::kNeon, KernelIsa::kBest}) {
    if (!kernel_isa_supported(isa)) continue;
    for (int layout = 0; layout < 5; ++layout) {
      std::vector<std::vector<uint32_t>> out(3, std::vector<uint32_t>(pixels.size(), 0xFFFFFFFFu));
      kernels::ForestKernelArgs a[3];
      for (int t = 0; t < 3; ++t) a[t] = args(t, mixes[layout][t], out[size_t(t)].data());
      kernels::forest_trees_kernel(isa)(a, 3);
      for (int t = 0; t < 3; ++t)
        EXPECT_EQ(out[size_t(t)], ref[size_t(t)]) << kernel_isa_name(isa) << " layout " << layout << " tree " << t;
    }
  }
}

class PclRealFramesSharedData : public testing::Test {
 protected:
  // PCL's three depth-20 trees from ../shared, converted here; or, when DP_PCL_BLOB names a file,
  // that blob (`depthpose convert --from-pcl` of the same trees: the aarch64 build has no arm64
  // libbz2, so make test-aarch64 converts them with the x86 CLI first).
  static void SetUpTestSuite() {
    if (const char* path = std::getenv("DP_PCL_BLOB")) {
      blob_bytes_ = new std::vector<uint8_t>(blob::read_blob_file(path));
      return;
    }
#if DP_NO_BZIP2
    blob_bytes_ = new std::vector<uint8_t>();  // the tests below fail naming DP_PCL_BLOB
#else
    std::vector<tools::PclTree> trees;
    for (int i = 1; i <= 3; ++i)
      trees.push_back(tools::read_pcl_tree(dp::test::shared_path("data/pcl-people-trees/forest") + std::to_string(i) +
                                           "_tree_20.txt.bz2"));
    blob_bytes_ = new std::vector<uint8_t>(blob::write_blob(tools::pcl_blob_contents(trees)));
#endif
  }
  void SetUp() override {
    ASSERT_FALSE(blob_bytes_->empty()) << "no PCL forest: this build reads no bzip2; set DP_PCL_BLOB to the blob "
                                          "`depthpose convert --from-pcl` makes of ../shared/data/pcl-people-trees";
  }
  static void TearDownTestSuite() {
    delete blob_bytes_;
    blob_bytes_ = nullptr;
  }
  static std::vector<uint8_t>* blob_bytes_;
};
std::vector<uint8_t>* PclRealFramesSharedData::blob_bytes_ = nullptr;

TEST_F(PclRealFramesSharedData, AllKernelsBitExactOnSkeltrackFrames) {
  const char* const names[] = {"1028894671", "1038901490", "1045879925", "1051883281", "1058893191", "1064898470",
                               "1070905432", "1078881076", "1166565565", "1234568668", "1399145206", "82823944"};
  Runner vga(*blob_bytes_, 640, 480);
  Runner qvga(*blob_bytes_, 320, 240);
  int compared = 0;
  for (const char* name : names) {
    const std::vector<uint16_t> depth =
        read_skeltrack(dp::test::shared_path("data/skeltrack-frames/depth-data-") + name + ".raw");
    DepthFrame f{depth.data(), 640, 480, 640, tools::kinect_intrinsics(640, 480), nullptr};
    compare_all_kernels(vga, f, std::string("skeltrack ") + name + " 640x480");
    // 2×2 subsampled, focal 262.5: focal_factor 500.
    std::vector<uint16_t> half(320 * 240);
    for (int v = 0; v < 240; ++v)
      for (int u = 0; u < 320; ++u) half[size_t(v) * 320 + u] = depth[size_t(2 * v) * 640 + 2 * u];
    DepthFrame h{half.data(), 320, 240, 320, tools::kinect_intrinsics(320, 240), nullptr};
    compare_all_kernels(qvga, h, std::string("skeltrack ") + name + " 320x240");
    ++compared;
  }
  EXPECT_EQ(compared, 12);
}

TEST_F(PclRealFramesSharedData, BlobDescribesPclForest) {
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(blob_bytes_->data(), blob_bytes_->size(), &b), blob::BlobStatus::kOk);
  EXPECT_EQ(b.tree_count(), 3);
  EXPECT_EQ(b.depth(), 20);
  EXPECT_EQ(b.meta->part_count, 25);
  EXPECT_STREQ(b.meta->part_names[19], "FaceLB");
  // One record per leaf node (blob_format.h), each one-hot on the PCL label of its slot.
  EXPECT_EQ(b.meta->leaf_count, blob::leaf_nodes_of(b.tree_node_count(0)) + blob::leaf_nodes_of(b.tree_node_count(1)) +
                                    blob::leaf_nodes_of(b.tree_node_count(2)));
  EXPECT_FLOAT_EQ(b.meta->reference_focal_px, 525.0f);
  EXPECT_LE(b.meta->max_abs_offset_pxm, uint32_t(kernels::kPackedMaxOffset));  // packed layout applies
  // Head = the four face parts.
  EXPECT_EQ(b.config->joints[0].part_mask, (1u << 19) | (1u << 20) | (1u << 21) | (1u << 22));
  // One-hot leaves.
  for (uint32_t l = 0; l < b.meta->leaf_count; ++l) {
    ASSERT_EQ(b.leaf_size(l), 1u) << "record " << l;
    EXPECT_LT(b.entry_tags[b.leaf_first(l)], 25);
    EXPECT_EQ(b.bpc_probabilities()[b.leaf_first(l)], 32768);
  }
}

namespace {
blob::RuntimeConfig with_budget(const blob::RuntimeConfig& base, uint64_t cycles) {
  blob::RuntimeConfig c = base;
  c.cycle_budget = cycles;
  return c;
}
constexpr uint32_t kBudgetFlags = kFlagBudgetPixels | kFlagBudgetVotes | kFlagBudgetStarts | kFlagBudgetIterations |
                                  kFlagBudgetInfeasible;
}  // namespace

TEST(CycleBudget, NoBudgetMeansNoDegradation) {
  Runner r(blob::write_blob(tools::random_bpc_forest(21, 3, 10, 8, 300, 200)), 320, 240);
  FrameResult res;
  ASSERT_EQ(r.pipeline.process(tools::make_disc_frame(320, 240, 160.0f, 120.0f, 50.0f, 2000).view(), &res), Status::kOk);
  EXPECT_EQ(res.flags & kBudgetFlags, 0u);
  EXPECT_EQ(res.votes_per_joint_used, r.pipeline.config().max_votes_per_joint);
  EXPECT_EQ(res.starts_per_joint_used, r.pipeline.config().max_starts_per_joint);
  EXPECT_EQ(res.iterations_used, r.pipeline.config().mean_shift_iterations);
  EXPECT_GT(res.predicted_cycles, 0u);
}

TEST(CycleBudget, DegradesInTheDocumentedOrderAndStaysWithinThePlan) {
  blob::BlobContents c = tools::random_bpc_forest(22, 3, 10, 8, 300, 200);
  c.config.max_evaluated_pixels = 320 * 240;
  Runner r(blob::write_blob(c), 320, 240);
  const SyntheticFrame f = tools::make_disc_frame(320, 240, 160.0f, 120.0f, 80.0f, 2000);  // ~20k pixels
  FrameResult full;
  ASSERT_EQ(r.pipeline.process(f.view(), &full), Status::kOk);
  ASSERT_EQ(full.flags & kBudgetFlags, 0u);
  const uint64_t unlimited = full.predicted_cycles;
  // Shrinking budgets: each step may add the next flag of the order, never skip one.
  const uint32_t order[] = {kFlagBudgetPixels, kFlagBudgetVotes, kFlagBudgetStarts, kFlagBudgetIterations};
  int32_t last_pixels = full.evaluated_pixels;
  bool saw_infeasible = false;
  for (uint64_t budget = unlimited * 9 / 10; budget > 1000; budget = budget * 7 / 10) {
    ASSERT_EQ(r.pipeline.set_config(with_budget(c.config, budget)), Status::kOk);
    FrameResult res;
    ASSERT_EQ(r.pipeline.process(f.view(), &res), Status::kOk);
    EXPECT_TRUE(res.flags & kFlagBudgetPixels) << budget;
    for (int k = 1; k < 4; ++k)
      if (res.flags & order[k]) {
        EXPECT_TRUE(res.flags & order[k - 1]) << "flag " << k << " without its predecessor";
      }
    if (res.flags & kFlagBudgetInfeasible) {
      saw_infeasible = true;
      EXPECT_EQ(res.votes_per_joint_used, 32);
      EXPECT_EQ(res.starts_per_joint_used, 4);
      EXPECT_EQ(res.iterations_used, 2);
    } else {
      EXPECT_LE(res.predicted_cycles, budget);
    }
    EXPECT_LE(res.evaluated_pixels, last_pixels);
    EXPECT_TRUE(res.flags & kFlagPixelsStrided);
    last_pixels = res.evaluated_pixels;
  }
  EXPECT_TRUE(saw_infeasible);
  EXPECT_GE(last_pixels, 900);  // the pixel floor (1000, by striding) holds
}

TEST(CycleBudget, DegradedFramesAreIdenticalAcrossKernels) {
  blob::BlobContents c = tools::random_bpc_forest(23, 3, 12, 8, 300, 200);
  c.config.max_evaluated_pixels = 320 * 240;
  c.config.cycle_budget = 2000000;
  Runner r(blob::write_blob(c), 320, 240);
  for (uint64_t s = 0; s < 2; ++s) compare_all_kernels(r, noisy_frame(40 + s, 320, 240).view(), "budgeted noisy");
  FrameResult res;
  ASSERT_EQ(r.pipeline.process(noisy_frame(40, 320, 240).view(), &res), Status::kOk);
  EXPECT_TRUE(res.flags & kFlagBudgetPixels);
}

// ---- vote casting: the SIMD kernels also select the fast vote casters (pipeline.cc); the scalar
// reference keeps the reference casters. Same votes means same proposals, flags and counts.

namespace {

// A random forest's structure with N joints, random part masks / thresholds / push-backs, and
// coarse leaf probabilities (many zeros and equal weights: exercises the tie order and the mass-0 skip).
blob::BlobContents random_bpc_joints(uint64_t seed, int joints, int nsub) {
  blob::BlobContents c = tools::random_bpc_forest(seed, 3, 10, 12, 400, 800);
  std::mt19937_64 rng(seed * 7 + 1);
  auto uni = [&](int lo, int hi) { return int(std::uniform_int_distribution<int>(lo, hi)(rng)); };
  for (size_t l = 0; l < c.bpc_leaves.size(); l += 12) {
    uint32_t raw[12], sum = 0;
    for (auto& r : raw) sum += (r = uint32_t(uni(0, 3) == 0 ? uni(1, 3) : 0));
    for (int p = 0; p < 12; ++p) c.bpc_leaves[l + p] = uint16_t(sum ? raw[p] * 32768u / sum : 0);
  }
  c.joint_names.clear();
  for (int j = 0; j < joints; ++j) c.joint_names.push_back("joint" + std::to_string(j));
  c.config = blob::default_runtime_config(joints);
  c.config.max_votes_per_joint = uint16_t(nsub);
  for (int j = 0; j < joints; ++j) {
    c.config.joints[j].part_mask = uint32_t(uni(1, (1 << 12) - 1));
    c.config.joints[j].prob_threshold_q15 = uint16_t(uni(0, 20000));
    c.config.joints[j].push_back_mm = int16_t(uni(0, 60));
  }
  return c;
}

// The same structure with random OJR leaves: K votes per joint, weights 0..3 (ties, no-vote lanes),
// offsets up to the format's limit kMaxVoteOffsetMm, vote lengths
// unlimited or short.
blob::BlobContents random_ojr_joints(uint64_t seed, int joints, int k, int nsub) {
  blob::BlobContents c = tools::random_bpc_forest(seed, 3, 10, 2, 400, 800);
  std::mt19937_64 rng(seed * 11 + 3);
  auto uni = [&](int lo, int hi) { return int(std::uniform_int_distribution<int>(lo, hi)(rng)); };
  const size_t leaves = c.bpc_leaves.size() / 2;
  c.method = blob::Method::kOjr;
  c.part_names.clear();
  c.bpc_leaves.clear();
  c.votes_per_joint = k;
  c.joint_names.clear();
  for (int j = 0; j < joints; ++j) c.joint_names.push_back("joint" + std::to_string(j));
  for (size_t l = 0; l < leaves * size_t(joints) * size_t(k); ++l) {
    auto off = [&] { return int16_t(uni(0, 50) == 0 ? (uni(0, 1) ? -blob::kMaxVoteOffsetMm : blob::kMaxVoteOffsetMm) : uni(-900, 900)); };
    c.ojr_leaves.push_back(blob::OjrVote{off(), off(), off(), uint16_t(uni(0, 3))});
  }
  c.config = blob::default_runtime_config(joints);
  c.config.max_votes_per_joint = uint16_t(nsub);
  for (int j = 0; j < joints; ++j) c.config.joints[j].vote_length_mm = uint16_t(uni(0, 1) ? 0 : uni(300, 1200));
  return c;
}

void compare_frames(Runner& r, const std::string& what) {
  compare_all_kernels(r, tools::make_disc_frame(320, 240, 150.0f, 100.0f, 70.0f, 2100).view(), what + " disc");
  for (uint64_t s = 0; s < 2; ++s)
    compare_all_kernels(r, noisy_frame(40 + s, 320, 240).view(), what + " noisy " + std::to_string(s));
}

}  // namespace

TEST(VoteCastingExactness, BpcRandomJointsTiesAndSmallNsub) {
  for (int joints : {1, 5, 13, 16})
    for (int nsub : {32, 200, 1024}) {
      Runner r(blob::write_blob(random_bpc_joints(uint64_t(joints * 100 + nsub), joints, nsub)), 320, 240);
      compare_frames(r, "bpc joints " + std::to_string(joints) + " nsub " + std::to_string(nsub));
    }
}

TEST(VoteCastingExactness, OjrRandomLeavesEveryKAndLengthLimit) {
  for (int k = 1; k <= blob::kMaxVotesPerLeafJoint; ++k)
    for (int joints : {3, 16})
      for (int nsub : {32, 500}) {
        Runner r(blob::write_blob(random_ojr_joints(uint64_t(k * 1000 + joints * 10 + nsub), joints, k, nsub)), 320,
                 240);
        compare_frames(r, "ojr k " + std::to_string(k) + " joints " + std::to_string(joints) + " nsub " +
                              std::to_string(nsub));
      }
}

TEST(VoteCastingExactnessSharedData, ShippedModelsOnSkeltrackFrames) {
  for (const char* model : {"models/bpc.blob", "models/ojr.blob"}) {
    Runner r(blob::read_blob_file(model), 640, 480);
    for (const char* name : {"1028894671", "1166565565", "82823944"}) {
      const std::vector<uint16_t> depth =
          read_skeltrack(dp::test::shared_path("data/skeltrack-frames/depth-data-") + name + ".raw");
      DepthFrame f{depth.data(), 640, 480, 640, tools::kinect_intrinsics(640, 480), nullptr};
      compare_all_kernels(r, f, std::string(model) + " skeltrack " + name);
    }
  }
}

TEST(VoteCastingExactness, PerUserVotesAgreeAcrossKernels) {
  Runner r(blob::write_blob(random_bpc_joints(77, 16, 64)), 320, 240);
  SyntheticFrame frame = tools::make_disc_frame(320, 240, 160.0f, 120.0f, 90.0f, 2000);
  std::vector<uint8_t> users(320 * 240, 0);
  for (int v = 0; v < 240; ++v)
    for (int u = 0; u < 320; ++u)
      if (frame.depth_mm[size_t(v) * 320 + u]) users[size_t(v) * 320 + u] = u < 160 ? 1 : 2;
  DepthFrame f = frame.view();
  f.foreground_mask = users.data();
  FrameResult ref[2], fast[2], all{};
  ASSERT_EQ(r.pipeline.set_kernel(KernelIsa::kScalar), Status::kOk);
  ASSERT_EQ(r.pipeline.process(f, &all), Status::kOk);
  for (int id = 1; id <= 2; ++id) ASSERT_EQ(r.pipeline.process_user(f, uint8_t(id), &ref[id - 1]), Status::kOk);
  ASSERT_EQ(r.pipeline.set_kernel(KernelIsa::kBest), Status::kOk);
  ASSERT_EQ(r.pipeline.process(f, &all), Status::kOk);
  for (int id = 1; id <= 2; ++id) ASSERT_EQ(r.pipeline.process_user(f, uint8_t(id), &fast[id - 1]), Status::kOk);
  for (int u = 0; u < 2; ++u) {
    EXPECT_EQ(ref[u].flags, fast[u].flags) << "user " << u + 1;
    int proposals = 0;
    for (int j = 0; j < 16; ++j) {
      ASSERT_EQ(ref[u].proposal_count[j], fast[u].proposal_count[j]) << "user " << u + 1 << " joint " << j;
      proposals += ref[u].proposal_count[j];
      EXPECT_EQ(0, std::memcmp(ref[u].proposals[j], fast[u].proposals[j],
                               sizeof(JointProposal) * size_t(ref[u].proposal_count[j])));
    }
    EXPECT_GT(proposals, 0) << "user " << u + 1 << " got no proposals: the comparison would be vacuous";
  }
}

// Every kernel of a kind this build and CPU run, by name: the dispatchable ISAs and, on x86-64, the
// SSE4.1 files (which the dispatch pairs with the AVX2 and AVX-512 kernels).
template <typename Fn>
std::vector<std::pair<std::string, Fn>> available(Fn (*lookup)(KernelIsa), Fn sse41) {
  std::vector<std::pair<std::string, Fn>> out;
  for (KernelIsa isa : kAllIsas)
    if (Fn fn = lookup(isa)) out.emplace_back(kernel_isa_name(isa), fn);
  if (sse41) out.emplace_back("sse41", sse41);
  return out;
}
#if defined(__x86_64__)
#define DP_SSE41(fn) &kernels::sse41::fn
#else
#define DP_SSE41(fn) nullptr
#endif
std::vector<std::pair<std::string, kernels::MeanShiftSumsFn>> sums_kernels() {
  return available<kernels::MeanShiftSumsFn>(&kernels::mean_shift_sums_kernel, DP_SSE41(mean_shift_sums));
}

// The mean-shift sums of every ISA equal the header's definition (16 lanes, lane = i mod 16, the
// fixed reduction tree) computed here in plain scalar code, bit for bit: near and far votes (kernel
// arguments beyond 80 give 0), zero weights, vote counts that are not multiples of 16.
// Mean shift climbs cell votes (mean_shift.h): votes sharing a one-bandwidth cell become one vote at
// their weighted centroid with their summed weight. Three votes in one cell and one vote 1 m away:
// two proposals, the heavier at the three votes' weighted centroid with their summed weight as its
// confidence; every start near the first mode is skipped, so there are exactly two modes.
TEST(MeanShiftCells, VotesInOneCellBecomeTheirWeightedCentroid) {
  blob::RuntimeConfig cfg = blob::default_runtime_config(1);
  cfg.joints[0].bandwidth_mm = 100;
  std::vector<Vote> votes(kVoteSlots);
  const float xs[4] = {0.31f, 0.32f, 0.33f, 1.5f}, ws[4] = {1.0f, 2.0f, 3.0f, 0.5f};
  for (uint32_t i = 0; i < 4; ++i) votes[i] = Vote{xs[i], 0.25f, 2.05f, ws[i], i, 1};
  int32_t counts[blob::kMaxJoints] = {4};
  std::vector<Vote> starts(blob::kMaxStartsCap);
  std::vector<float> modes(size_t(blob::kMaxStartsCap) * 4), soa(size_t(kSoaRow) * 4);
  std::vector<uint64_t> keys(kCellSlots);
  std::vector<int32_t> ids(kCellSlots);
  for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kBest}) {
    FrameResult r{};
    r.starts_per_joint_used = 24;
    r.iterations_used = 12;
    const kernels::KernelSet k =
        kernels::kernel_set(isa == KernelIsa::kBest ? widest_kernel_isa() : isa, KernelIsa::kScalar);
    aggregate_proposals(cfg, 1, VoteSets{votes.data(), counts, nullptr},
                        MeanShiftScratch{starts.data(), modes.data(), soa.data(), keys.data(), ids.data()},
                        MeanShiftKernels{k.mean_shift_sums, k.mode_weights}, &r);
    ASSERT_EQ(r.proposal_count[0], 2) << kernel_isa_name(isa);
    const float cx = (0.31f * 1.0f + 0.32f * 2.0f + 0.33f * 3.0f) / 6.0f;
    EXPECT_NEAR(r.proposals[0][0].x_m, cx, 1e-6f);
    EXPECT_NEAR(r.proposals[0][0].y_m, 0.25f, 1e-6f);
    EXPECT_NEAR(r.proposals[0][0].z_m, 2.05f, 1e-6f);
    EXPECT_FLOAT_EQ(r.proposals[0][0].confidence, 6.0f);
    EXPECT_NEAR(r.proposals[0][1].x_m, 1.5f, 1e-6f);
    EXPECT_FLOAT_EQ(r.proposals[0][1].confidence, 0.5f);
  }
}

TEST(MeanShiftKernel, EveryIsaComputesTheDefinedSums) {
  std::mt19937_64 rng(91);
  std::uniform_real_distribution<float> coord(-1.5f, 1.5f), depth(0.5f, 4.5f), weight(0.0f, 3.0f);
  for (int32_t nv : {1, 3, 16, 17, 200, 333, 1024}) {
    const int32_t padded = (nv + 15) & ~15;
    std::vector<float> x(padded, 0.0f), y(padded, 0.0f), z(padded, 0.0f), w(padded, 0.0f);
    for (int32_t i = 0; i < nv; ++i) {
      x[i] = coord(rng); y[i] = coord(rng); z[i] = depth(rng);
      w[i] = (rng() % 7 == 0) ? 0.0f : weight(rng);
      if (i % 11 == 5) { x[i] = x[i - 1]; y[i] = y[i - 1]; z[i] = z[i - 1]; }  // duplicates
    }
    for (int trial = 0; trial < 20; ++trial) {
      const float mx = coord(rng), my = coord(rng), mz = depth(rng);
      const float b = 0.02f + 0.2f * float(trial % 5);  // small bandwidths: many arguments ≥ 80
      const float inv_b2 = 1.0f / (b * b);
      float lane[4][16] = {};
      for (int32_t i = 0; i < padded; ++i) {
        const float dx = x[i] - mx, dy = y[i] - my, dz = z[i] - mz;
        const float d2 = (dx * dx + dy * dy) + dz * dz;
        const float k = w[i] * exp_neg(d2 * inv_b2);
        lane[0][i % 16] += k;
        lane[1][i % 16] += k * x[i];
        lane[2][i % 16] += k * y[i];
        lane[3][i % 16] += k * z[i];
      }
      float expect[4];
      for (int c = 0; c < 4; ++c) {
        float s[16];
        for (int l = 0; l < 16; ++l) s[l] = lane[c][l];
        for (int half = 8; half >= 1; half /= 2)
          for (int l = 0; l < half; ++l) s[l] = s[l] + s[l + half];
        expect[c] = s[0];
      }
      for (const auto& [name, fn] : sums_kernels()) {
        float out[4];
        fn(x.data(), y.data(), z.data(), w.data(), padded, mx, my, mz, inv_b2, out);
        EXPECT_EQ(0, std::memcmp(out, expect, sizeof out))
            << name << " nv " << nv << " trial " << trial << ": " << out[0] << " vs " << expect[0];
      }
    }
  }
}

namespace {
// A deterministic stand-in for the pipeline's cut: keeps every other vote; the new floor is half the
// heaviest kept weight, never below the joint's floor before (the contract), so later appends
// exercise the floor reload.
struct ScanSink {
  std::vector<Vote> votes;
  std::vector<int32_t> counts;
  std::vector<float> cuts;
  int32_t slots;
  alignas(64) float floor[kMaxJoints];
  float last_floor[kMaxJoints] = {};  // what sink_cut returned last, per joint
};
float sink_cut(void* ctx, int j) {
  ScanSink* s = static_cast<ScanSink*>(ctx);
  Vote* buf = s->votes.data() + size_t(j) * size_t(s->slots);
  int32_t out = 0;
  float heaviest = 0.0f;
  for (int32_t i = 0; i < s->counts[j]; i += 2) {
    buf[out++] = buf[i];
    heaviest = std::max(heaviest, buf[i].weight);
  }
  s->counts[j] = out;
  s->cuts.push_back(float(j));
  s->last_floor[j] = std::max(s->last_floor[j], heaviest * 0.5f);
  return s->last_floor[j];
}
}  // namespace

// The BPC vote scan of every ISA (ref, SSE4.1, AVX2, AVX-512 or NEON) appends exactly the votes of
// vote_kernel.h's contract, computed here in scalar code: random joint masses (zeros, ties, sums at
// the Q15 limit), floors below, inside and above the weights, a user filter, full buffers.
TEST(BpcScanKernel, EveryIsaAppendsTheContractsVotes) {
  std::mt19937_64 rng(17);
  const int32_t leaves = 300, n = 2000, trees = 3, slots = 64;
  std::vector<uint16_t> mass(size_t(leaves) * kMaxJoints, 0);
  for (auto& m : mass) m = uint16_t(rng() % 3 == 0 ? 0 : rng() % 4 == 0 ? 32768 : (rng() % 8) * 4096);
  std::vector<EvaluatedPixel> px(n);
  std::vector<uint32_t> leaf(size_t(trees) * n);
  std::vector<uint8_t> users(64 * 64);
  for (auto& u : users) u = uint8_t(rng() % 3);
  for (int32_t i = 0; i < n; ++i) {
    px[i] = EvaluatedPixel{uint16_t(rng() % 64), uint16_t(rng() % 64), uint16_t(400 + rng() % 5000), 0};
    for (int t = 0; t < trees; ++t) leaf[size_t(t) * n + i] = uint32_t(rng() % leaves);
  }
  float push[kMaxJoints];
  uint32_t thr[kMaxJoints];
  for (int j = 0; j < kMaxJoints; ++j) { push[j] = float(rng() % 60) * 0.001f; thr[j] = uint32_t(rng() % 20000) * trees; }
  const float inv_total = 1.0f / (32768.0f * trees);
  for (int trial = 0; trial < 6; ++trial) {
    float floor0[kMaxJoints];
    for (int j = 0; j < kMaxJoints; ++j)
      floor0[j] = trial == 0 ? -1.0f : j % 5 == 0 ? __builtin_inff() : float(rng() % 100) * 0.02f;
    const bool filtered = trial % 2 == 1;
    auto run_scan = [&](kernels::BpcScanFn fn, ScanSink* sink, uint32_t* cand) {
      sink->slots = slots;
      sink->votes.assign(size_t(kMaxJoints) * slots, Vote{});
      sink->counts.assign(kMaxJoints, 0);
      std::memcpy(sink->floor, floor0, sizeof floor0);
      std::memcpy(sink->last_floor, floor0, sizeof floor0);
      kernels::BpcScanArgs a{px.data(), n, leaf.data(), n, trees, mass.data(), inv_total, 31.5f, 30.0f,
                             1.0f / 285.0f, 1.0f / 286.0f, push, thr, sink->floor, filtered ? users.data() : nullptr,
                             64, uint8_t(1), sink->votes.data(), slots, sink->counts.data(), cand, &sink_cut, sink};
      fn(a);
    };
    // The contract in scalar code.
    ScanSink model;
    model.slots = slots;
    model.votes.assign(size_t(kMaxJoints) * slots, Vote{});
    model.counts.assign(kMaxJoints, 0);
    std::memcpy(model.floor, floor0, sizeof floor0);
    std::memcpy(model.last_floor, floor0, sizeof floor0);
    uint32_t model_cand[kMaxJoints] = {};
    for (int32_t i = 0; i < n; ++i) {
      if (filtered && users[size_t(px[i].v) * 64 + px[i].u] != 1) continue;
      const float z = float(px[i].z_mm) * 0.001f;
      const float x = (float(px[i].u) - 31.5f) * z * (1.0f / 285.0f), y = -(float(px[i].v) - 30.0f) * z * (1.0f / 286.0f);
      for (int j = 0; j < kMaxJoints; ++j) {
        uint32_t m = 0;
        for (int t = 0; t < trees; ++t) m += mass[size_t(leaf[size_t(t) * n + i]) * kMaxJoints + j];
        if (m == 0) continue;
        ++model_cand[j];
        const float wt = float(m) * inv_total * z * z;
        if (wt < model.floor[j]) continue;
        model.votes[size_t(j) * slots + model.counts[j]++] = Vote{x, y, z + push[j], wt, uint32_t(i), m > thr[j] ? 1u : 0u};
        if (model.counts[j] == slots) model.floor[j] = sink_cut(&model, j);
      }
    }
    ASSERT_GT(model.cuts.size(), 0u);
    ASSERT_GE(available<kernels::BpcScanFn>(&kernels::bpc_scan_kernel, DP_SSE41(bpc_scan)).size(), 2u);
    for (const auto& [name, fn] : available<kernels::BpcScanFn>(&kernels::bpc_scan_kernel, DP_SSE41(bpc_scan))) {
      ScanSink got;
      uint32_t cand[kMaxJoints] = {};
      run_scan(fn, &got, cand);
      const std::string what = name + " trial " + std::to_string(trial);
      EXPECT_EQ(0, std::memcmp(cand, model_cand, sizeof cand)) << what;
      EXPECT_EQ(got.cuts, model.cuts) << what;
      ASSERT_EQ(got.counts, model.counts) << what;
      for (int j = 0; j < kMaxJoints; ++j)
        EXPECT_EQ(0, std::memcmp(got.votes.data() + size_t(j) * slots, model.votes.data() + size_t(j) * slots,
                                 sizeof(Vote) * size_t(model.counts[j])))
            << what << " joint " << j;
    }
  }
}

// 4096 pixels with random leaves, every 16th far (4000 mm against 500): the fast casters' floor
// guess samples every 8th pixel, so half its samples are heavy and it lands above the reference's
// top-Nsub; the fast casters must rescan, and their proposals and flags must equal the reference's
// on every SIMD kernel.
static void expect_fast_casters_match_reference_with_far_samples(Runner& r, uint64_t seed) {
  const int32_t n = 4096, trees = r.view.tree_count();
  std::mt19937_64 rng(seed);
  std::vector<EvaluatedPixel> px(n);
  std::vector<uint32_t> leaves(size_t(trees) * n);
  for (int32_t i = 0; i < n; ++i) {
    px[i] = EvaluatedPixel{uint16_t(rng() % 320), uint16_t(rng() % 240), uint16_t(i % 16 == 0 ? 4000 : 500), 0};
    for (int t = 0; t < trees; ++t) leaves[size_t(t) * n + i] = uint32_t(rng() % r.view.meta->leaf_count);
  }
  const CameraIntrinsics intr = tools::kinect_intrinsics(320, 240);
  FrameResult ref{}, fast{};
  ASSERT_EQ(r.pipeline.set_kernel(KernelIsa::kScalar), Status::kOk);
  ASSERT_EQ(r.pipeline.aggregate_from_leaves(intr, px.data(), leaves.data(), n, &ref), Status::kOk);
  int proposals = 0;
  for (int j = 0; j < 16; ++j) proposals += ref.proposal_count[j];
  EXPECT_GT(proposals, 0);
  for (KernelIsa isa : kSimdIsas) {
    if (!kernel_isa_supported(isa)) continue;
    ASSERT_EQ(r.pipeline.set_kernel(isa), Status::kOk);
    ASSERT_EQ(r.pipeline.aggregate_from_leaves(intr, px.data(), leaves.data(), n, &fast), Status::kOk);
    EXPECT_EQ(ref.flags, fast.flags) << kernel_isa_name(isa);
    for (int j = 0; j < 16; ++j) {
      ASSERT_EQ(ref.proposal_count[j], fast.proposal_count[j]) << kernel_isa_name(isa) << " joint " << j;
      EXPECT_EQ(0, std::memcmp(ref.proposals[j], fast.proposals[j], sizeof(JointProposal) * size_t(ref.proposal_count[j])))
          << kernel_isa_name(isa) << " joint " << j;
    }
  }
}

// The fast BPC caster guesses each joint's floor from every k-th pixel. Here the sampled pixels
// are far (z² makes them ~60x heavier) and Nsub exceeds their number, so the guess is too high for
// every joint and must be caught and rescanned: the kernels must still agree with the reference.
TEST(VoteCastingExactness, BpcFloorGuessTooHighIsRescanned) {
  Runner r(blob::write_blob(random_bpc_joints(5, 16, 500)), 320, 240);
  expect_fast_casters_match_reference_with_far_samples(r, 3);
}

// The OJR caster's floor guess from every k-th pixel: here every 16th pixel is far (weights ×64),
// so the sampled pixels (every 8th) are half heavy and the guess lands above the reference's
// top-Nsub; the joints left short must be scanned again for the kept votes to be the same.
TEST(VoteCastingExactness, OjrFloorGuessTooHighIsRescanned) {
  Runner r(blob::write_blob(random_ojr_joints(9, 16, 2, 500)), 320, 240);
  expect_fast_casters_match_reference_with_far_samples(r, 4);
}

// The live-vote copy holds, per record and in the record's order, exactly the stored votes that are
// candidates (weight ≠ 0, |offset|² ≤ the lane's vote length²) under the config it was built for.
TEST(OjrLiveVotes, HoldExactlyTheCandidatesInRecordOrder) {
  const std::vector<uint8_t> bytes = blob::write_blob(random_ojr_joints(12, 16, 3, 200));
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  ASSERT_TRUE(use_ojr_live_votes(b));
  std::vector<uint32_t> offsets(b.meta->leaf_count + 1);
  std::vector<blob::OjrVote> votes(b.meta->entry_count);
  std::vector<uint8_t> lanes(b.meta->entry_count);
  build_ojr_live_votes(b, *b.config, offsets.data(), votes.data(), lanes.data());
  const int k = b.meta->votes_per_joint;
  uint32_t n = 0, dead = 0;
  for (uint32_t r = 0; r < b.meta->leaf_count; ++r) {
    ASSERT_EQ(offsets[r], n) << "record " << r;
    for (uint32_t e = b.leaf_first(r); e < b.leaf_offsets[r + 1]; ++e) {
      const blob::OjrVote& v = b.ojr_votes()[e];
      const uint64_t len = b.config->joints[b.entry_tags[e] / k].vote_length_mm;
      const uint64_t d2 = uint64_t(int64_t(v.dx_mm) * v.dx_mm + int64_t(v.dy_mm) * v.dy_mm + int64_t(v.dz_mm) * v.dz_mm);
      if (v.weight == 0 || (len != 0 && d2 > len * len)) {
        ++dead;
        continue;
      }
      ASSERT_EQ(std::memcmp(&votes[n], &v, sizeof v), 0) << "record " << r << " vote " << e;
      ASSERT_EQ(lanes[n++], b.entry_tags[e]) << "record " << r << " vote " << e;
    }
  }
  EXPECT_EQ(offsets[b.meta->leaf_count], n);
  EXPECT_GT(dead, 0u);  // the random blob has weightless and too-long votes: the copy is smaller
  EXPECT_GT(n, 0u);
}

// Without the optional copy (a minimum arena) the fast OJR caster scans the blob's votes in place;
// with it, the live-vote copy. Both equal the reference, and the copy is the arena difference.
TEST(VoteCastingExactness, OjrInPlaceScanEqualsTheLiveCopy) {
  Runner with_copy(blob::write_blob(random_ojr_joints(21, 16, 2, 300)), 320, 240);
  const blob::LoadedBlob& b = with_copy.view;
  const size_t minimum = minimum_arena_bytes(b, 320, 240);
  const size_t live = (size_t(b.meta->leaf_count) + 1) * 4 + size_t(b.meta->entry_count) * 9;
  EXPECT_GE(required_arena_bytes(b, 320, 240) - minimum, live);
  EXPECT_LT(required_arena_bytes(b, 320, 240) - minimum, live + 4 * 64);  // the arrays and their alignment
  std::unique_ptr<uint8_t, decltype(&std::free)> small(static_cast<uint8_t*>(std::aligned_alloc(64, (minimum + 63) / 64 * 64)),
                                                       &std::free);
  Pipeline in_place;
  ASSERT_EQ(in_place.init(b, 320, 240, small.get(), minimum), Status::kOk);
  for (uint64_t s = 0; s < 2; ++s) {
    const SyntheticFrame f = noisy_frame(60 + s, 320, 240);
    const Outcome ref = run(with_copy, KernelIsa::kScalar, f.view());
    expect_identical(ref, run(with_copy, KernelIsa::kBest, f.view()), "live copy");
    Outcome direct;
    ASSERT_EQ(in_place.set_kernel(KernelIsa::kBest), Status::kOk);
    ASSERT_EQ(in_place.process(f.view(), &direct.result), Status::kOk);
    for (int t = 0; t < b.tree_count(); ++t)
      for (int32_t i = 0; i < in_place.evaluated_pixel_count(); ++i) direct.leaves.push_back(in_place.leaf_of(i, t));
    expect_identical(ref, direct, "in place");
  }
}

// set_config rebuilds the live-vote copy: after the vote lengths change (limited ↔ unlimited, longer,
// shorter), the fast casters still keep the reference's votes.
TEST(VoteCastingExactness, OjrLiveCopyFollowsSetConfig) {
  Runner r(blob::write_blob(random_ojr_joints(33, 16, 2, 400)), 320, 240);
  blob::RuntimeConfig cfg = r.pipeline.config();
  for (int round = 0; round < 2; ++round) {
    for (int j = 0; j < 16; ++j) {
      const uint16_t len = cfg.joints[j].vote_length_mm;
      cfg.joints[j].vote_length_mm = uint16_t(len == 0 ? 400 + 50 * j : (j % 3 == 0 ? 0 : len / 2 + 100 * round));
    }
    ASSERT_EQ(r.pipeline.set_config(cfg), Status::kOk);
    compare_frames(r, "ojr after set_config " + std::to_string(round));
  }
}

// Stage 1 (foreground, eight pixels at a time) lists exactly the pixels of its definition: depth
// nonzero, below kBackgroundDepthMm, and in [near, far] or nonzero in the mask; raster order;
// every stride-th one when over budget. Odd widths (scalar tail), depths at and above the background
// value, and a strided frame.
TEST(ForegroundStage, ListsTheDefinedPixels) {
  std::mt19937_64 rng(8);
  for (int trial = 0; trial < 6; ++trial) {
    const int w = trial % 2 ? 317 : 320, h = 237;
    blob::BlobContents c = random_bpc_joints(9, 4, 64);
    c.config.near_mm = uint16_t(500 + trial * 100);
    c.config.far_mm = uint16_t(3000 + trial * 300);
    const int32_t budget = trial == 5 ? 5000 : 320 * 240;  // trial 5 is strided
    c.config.max_evaluated_pixels = uint32_t(budget);
    Runner r(blob::write_blob(c), 320, 240);
    std::vector<uint16_t> depth(size_t(w + 3) * h);
    std::vector<uint8_t> mask(depth.size());
    const uint16_t special[] = {0, 1, kBackgroundDepthMm - 1, kBackgroundDepthMm, kBackgroundDepthMm + 1, 65535,
                                c.config.near_mm, uint16_t(c.config.near_mm - 1), c.config.far_mm, uint16_t(c.config.far_mm + 1)};
    for (auto& d : depth) d = rng() % 4 == 0 ? special[rng() % 10] : uint16_t(rng() % 6000);
    for (auto& m : mask) m = uint8_t(rng() % 3 == 0 ? 0 : rng() % 5);
    const bool use_mask = trial >= 3;
    DepthFrame f{depth.data(), w, h, w + 3, tools::kinect_intrinsics(w, h), use_mask ? mask.data() : nullptr};
    std::vector<EvaluatedPixel> expect;
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        const uint16_t z = depth[size_t(v) * (w + 3) + u];
        const bool in = z != 0 && z < kBackgroundDepthMm &&
                        (use_mask ? mask[size_t(v) * (w + 3) + u] != 0 : z >= c.config.near_mm && z <= c.config.far_mm);
        if (in) expect.push_back(EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0});
      }
    FrameResult res{};
    ASSERT_EQ(r.pipeline.process(f, &res), Status::kOk);
    EXPECT_EQ(res.foreground_pixels, int32_t(expect.size())) << trial;
    const int32_t stride = res.pixel_stride;
    EXPECT_EQ(stride > 1, trial == 5) << trial;
    std::vector<EvaluatedPixel> strided;
    for (size_t i = 0; i < expect.size() && int32_t(strided.size()) < budget; i += size_t(stride)) strided.push_back(expect[i]);
    ASSERT_EQ(r.pipeline.evaluated_pixel_count(), int32_t(strided.size())) << trial;
    EXPECT_EQ(0, std::memcmp(r.pipeline.evaluated_pixels(), strided.data(), strided.size() * sizeof(EvaluatedPixel))) << trial;
  }
}

// The kernels the dispatch pairs with every SIMD ISA on x86-64 (SSE4.1 foreground scan, OJR vote
// scan, mode weights) against their ref/ specification, called directly on random inputs.
#if defined(__x86_64__)
TEST(Sse41Kernels, ForegroundScanEqualsTheReference) {
  std::mt19937_64 rng(31);
  for (int trial = 0; trial < 8; ++trial) {
    const int w = 1 + int(rng() % 70), h = 1 + int(rng() % 20), stride = w + int(rng() % 5);
    std::vector<uint16_t> depth(size_t(stride) * h);
    std::vector<uint8_t> mask(depth.size());
    const uint16_t special[] = {0, 1, 499, 500, 3000, 3001, kBackgroundDepthMm - 1, kBackgroundDepthMm, 65535};
    for (auto& d : depth) d = rng() % 3 == 0 ? special[rng() % 9] : uint16_t(rng() % 7000);
    for (auto& m : mask) m = uint8_t(rng() % 3);
    const int32_t cap = trial == 3 ? 7 : w * h;
    auto run = [&](kernels::ForegroundScanFn fn, std::vector<uint16_t>* probe, std::vector<EvaluatedPixel>* px) {
      probe->assign(kernels::padded_probe_elements(w, h), 0x1234);
      px->assign(size_t(w) * h, EvaluatedPixel{0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF});
      const kernels::ForegroundScanArgs a{depth.data(), w, h, stride, trial % 2 ? mask.data() : nullptr, 500, 3000,
                                          probe->data(), px->data(), cap};
      return fn(a);
    };
    std::vector<uint16_t> ref_probe, probe;
    std::vector<EvaluatedPixel> ref_px, px;
    const kernels::ForegroundScanResult want = run(&kernels::ref::foreground_scan, &ref_probe, &ref_px);
    const kernels::ForegroundScanResult got = run(&kernels::sse41::foreground_scan, &probe, &px);
    EXPECT_EQ(got.foreground, want.foreground) << trial;
    EXPECT_EQ(got.listed, want.listed) << trial;
    EXPECT_EQ(probe, ref_probe) << trial;
    EXPECT_EQ(0, std::memcmp(px.data(), ref_px.data(), px.size() * sizeof(EvaluatedPixel))) << trial;
    EXPECT_GT(want.foreground, 0) << trial;
  }
}

TEST(Sse41Kernels, ModeWeightsEqualTheReference) {
  std::mt19937_64 rng(32);
  std::uniform_real_distribution<float> coord(-0.5f, 0.5f), weight(0.0f, 2.0f);
  for (int32_t nv : {1, 3, 4, 5, 64, 333}) {
    const int32_t padded = (nv + 15) & ~15;
    std::vector<float> x(padded), y(padded), z(padded), w(padded);
    for (int32_t i = 0; i < padded; ++i) { x[i] = coord(rng); y[i] = coord(rng); z[i] = 2.0f + coord(rng); w[i] = weight(rng); }
    for (int32_t nm : {0, 1, 2, 17}) {
      std::vector<float> modes(size_t(nm) * 4), ref_modes;
      for (int32_t m = 0; m < nm; ++m) {
        modes[4 * m] = coord(rng); modes[4 * m + 1] = coord(rng); modes[4 * m + 2] = 2.0f + coord(rng);
        modes[4 * m + 3] = 0.0f;
      }
      if (nm == 17) modes[4 * 5 + 0] = modes[4 * 3 + 0], modes[4 * 5 + 1] = modes[4 * 3 + 1], modes[4 * 5 + 2] = modes[4 * 3 + 2];
      ref_modes = modes;
      kernels::ref::mode_weights(x.data(), y.data(), z.data(), w.data(), nv, ref_modes.data(), nm, 0.09f);
      kernels::sse41::mode_weights(x.data(), y.data(), z.data(), w.data(), nv, modes.data(), nm, 0.09f);
      if (nm > 0) {  // no modes: nothing to compare (memcmp may not be handed an empty vector's null data)
        EXPECT_EQ(0, std::memcmp(modes.data(), ref_modes.data(), modes.size() * sizeof(float))) << nv << " " << nm;
      }
    }
  }
}

// Compact leaves of every shape: empty records, full ones (all joints·K lanes), every length mod 4
// (the vector steps and the scalar tail), lanes in any increasing subset, extreme offsets (±32768:
// pmaddwd's wrap) and weights 0 (outside validated blobs, but inside the kernel's contract).
TEST(Sse41Kernels, OjrScanEqualsTheReference) {
  std::mt19937_64 rng(33);
  const int32_t n = 1500, trees = 3, records = 200;
  for (int k_votes : {1, 2, 3, 4}) {
    const int joints = k_votes == 4 ? 16 : 1 + int(rng() % 16), lanes = joints * k_votes;
    std::vector<blob::OjrVote> votes;
    std::vector<uint8_t> vote_lanes;
    std::vector<uint32_t> offsets{0};
    for (int r = 0; r < records; ++r) {
      const int shape = r % 4;  // 0: random subset, 1: every lane, 2: none, 3: 1..3 lanes from a random start
      const int few = 1 + (r / 4) % 3, start = int(rng() % uint64_t(lanes));
      for (int l = 0; l < lanes; ++l) {
        const bool stored = shape == 1 || (shape == 0 && rng() % 2 == 0) || (shape == 3 && l >= start && l < start + few);
        if (!stored) continue;
        auto off = [&] { return int16_t(rng() % 8 == 0 ? (rng() % 2 ? 32767 : -32768) : int(rng() % 4001) - 2000); };
        votes.push_back(blob::OjrVote{off(), off(), off(), uint16_t(rng() % 4 == 0 ? 0 : rng() % 5)});
        vote_lanes.push_back(uint8_t(l));
      }
      offsets.push_back(uint32_t(votes.size()));
    }
    std::vector<bool> length_seen(static_cast<size_t>(lanes) + 1, false);
    for (int r = 0; r < records; ++r) length_seen[offsets[r + 1] - offsets[r]] = true;
    for (int len : {0, 1, 2, 3, lanes}) EXPECT_TRUE(len > lanes || length_seen[size_t(len)]) << "record length " << len;
    std::vector<EvaluatedPixel> px(n);
    std::vector<uint32_t> leaf(size_t(trees) * n);
    for (int32_t i = 0; i < n; ++i) {
      px[i] = EvaluatedPixel{uint16_t(rng() % 64), uint16_t(rng() % 64), uint16_t(400 + rng() % 5000), 0};
      for (int t = 0; t < trees; ++t) leaf[size_t(t) * n + i] = uint32_t(rng() % records);
    }
    std::vector<uint32_t> len2(static_cast<size_t>(lanes));
    for (int l = 0; l < lanes; ++l) {
      const uint32_t len = (l / k_votes) % 3 == 0 ? 0 : uint32_t(rng() % 3000);
      len2[size_t(l)] = len == 0 ? 0xFFFFFFFFu : len * len;
    }
    std::vector<uint8_t> users(64 * 64);
    for (auto& u : users) u = uint8_t(rng() % 3);
    for (int trial = 0; trial < 4; ++trial) {
      auto run = [&](kernels::OjrScanFn fn, ScanSink* sink, std::vector<int32_t>* cand) {
        sink->slots = 64;
        sink->votes.assign(size_t(kMaxJoints) * 64, Vote{});
        sink->counts.assign(kMaxJoints, 0);
        cand->assign(kernels::kMaxOjrLanes, 0);
        alignas(16) float lane_floor[kernels::kMaxOjrLanes];
        for (int l = 0; l < kernels::kMaxOjrLanes; ++l) lane_floor[l] = trial == 0 ? -1.0f : float((l / k_votes) % 4) * 2.0f;
        for (int j = 0; j < kMaxJoints; ++j) sink->last_floor[j] = trial == 0 ? -1.0f : float(j % 4) * 2.0f;
        alignas(16) int32_t counted[kernels::kMaxOjrLanes] = {};
        const kernels::OjrScanArgs a{px.data(), n, leaf.data(), n, trees, offsets.data(), votes.data(),
                                     vote_lanes.data(), lanes, k_votes, 31.5f, 30.0f, 1.0f / 285.0f,
                                     1.0f / 286.0f, len2.data(), lane_floor, trial % 2 ? users.data() : nullptr, 64,
                                     uint8_t(2), sink->votes.data(), 64, 48, sink->counts.data(), counted, &sink_cut, sink};
        fn(a);
        cand->assign(counted, counted + kernels::kMaxOjrLanes);
      };
      ScanSink want, got;
      std::vector<int32_t> want_cand, got_cand;
      run(&kernels::ref::ojr_scan, &want, &want_cand);
      run(&kernels::sse41::ojr_scan, &got, &got_cand);
      const std::string what = "K " + std::to_string(k_votes) + " trial " + std::to_string(trial);
      ASSERT_GT(want.cuts.size(), 0u) << what;
      EXPECT_EQ(got_cand, want_cand) << what;
      EXPECT_EQ(got.cuts, want.cuts) << what;
      ASSERT_EQ(got.counts, want.counts) << what;
      for (int j = 0; j < kMaxJoints; ++j)
        EXPECT_EQ(0, std::memcmp(got.votes.data() + size_t(j) * 64, want.votes.data() + size_t(j) * 64,
                                 sizeof(Vote) * size_t(want.counts[j])))
            << what << " joint " << j;
    }
  }
}
#endif

// The reference's bits on one architecture equal its bits on the other: digests of every leaf and
// every proposal (PCL's forest and the shipped models on three Skeltrack frames, the reference
// kernels) are written by the x86-64 run when DP_DIGESTS_OUT names a file, and compared line by
// line by the aarch64 run (make test-aarch64) when DP_DIGESTS_EXPECTED names that file. Either way
// the widest kernels must give the reference's digest.
namespace {
uint64_t fnv1a(uint64_t h, const void* data, size_t bytes) {
  const uint8_t* p = static_cast<const uint8_t*>(data);
  for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}
uint64_t digest(const Outcome& o) {
  uint64_t h = 14695981039346656037ull;
  h = fnv1a(h, o.leaves.data(), o.leaves.size() * sizeof(uint32_t));
  const FrameResult& r = o.result;
  h = fnv1a(h, &r.joint_count, sizeof r.joint_count);
  h = fnv1a(h, r.proposal_count, sizeof r.proposal_count);
  for (int j = 0; j < r.joint_count; ++j) h = fnv1a(h, r.proposals[j], sizeof(JointProposal) * size_t(r.proposal_count[j]));
  const uint32_t flags = r.flags & ~uint32_t(kFlagOverCycleBudget);
  h = fnv1a(h, &flags, sizeof flags);
  h = fnv1a(h, &r.evaluated_pixels, sizeof r.evaluated_pixels);
  return h;
}
}  // namespace

TEST_F(PclRealFramesSharedData, ReferenceDigestsAgreeAcrossArchitectures) {
  std::vector<std::pair<std::string, std::vector<uint8_t>>> models = {{"pcl", *blob_bytes_}};
  for (const char* m : {"models/bpc.blob", "models/ojr.blob"}) models.emplace_back(m, blob::read_blob_file(m));
  std::string lines;
  for (auto& [name, bytes] : models) {
    Runner r(bytes, 640, 480);
    for (const char* frame : {"1028894671", "1166565565", "82823944"}) {
      const std::vector<uint16_t> depth =
          read_skeltrack(dp::test::shared_path("data/skeltrack-frames/depth-data-") + frame + ".raw");
      const DepthFrame f{depth.data(), 640, 480, 640, tools::kinect_intrinsics(640, 480), nullptr};
      const uint64_t ref = digest(run(r, KernelIsa::kScalar, f));
      EXPECT_EQ(digest(run(r, KernelIsa::kBest, f)), ref) << name << " " << frame;
      char line[160];
      std::snprintf(line, sizeof line, "%s %s %016llx\n", name.c_str(), frame, static_cast<unsigned long long>(ref));
      lines += line;
    }
  }
  if (const char* out = std::getenv("DP_DIGESTS_OUT")) {
    std::ofstream(out) << lines;
  }
  if (const char* expected = std::getenv("DP_DIGESTS_EXPECTED")) {
    std::ifstream in(expected);
    ASSERT_TRUE(in.good()) << expected << ": the digests of the other architecture's run are missing";
    const std::string want((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(lines, want) << "the reference's bits differ between architectures";
  }
}
