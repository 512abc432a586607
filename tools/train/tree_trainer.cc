#include "tools/train/tree_trainer.h"

#include <immintrin.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <cmath>
#include <exception>
#include <mutex>
#include <thread>

#include "runtime/fixed_point.h"
#include "tools/common/error.h"

namespace dp::train {
using tools::fail;

void parallel_for(size_t n, int threads, const std::function<void(size_t, int)>& fn) {
  std::atomic<size_t> next{0};
  std::mutex mutex;
  size_t failed_at = SIZE_MAX;
  std::exception_ptr error;
  auto worker = [&](int thread) {
    for (;;) {
      const size_t i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= n) return;
      try {
        fn(i, thread);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (i < failed_at) {
          failed_at = i;
          error = std::current_exception();
        }
        next.store(n);
        return;
      }
    }
  };
  const int t = static_cast<int>(std::min<size_t>(std::max(1, threads), std::max<size_t>(n, 1)));
  std::vector<std::thread> pool;
  for (int i = 1; i < t; ++i) pool.emplace_back(worker, i);
  worker(0);
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

namespace {

constexpr int kNLogNTable = 4096;
struct NLogN {
  double v[kNLogNTable];
  NLogN() {
    v[0] = 0;
    for (int i = 1; i < kNLogNTable; ++i) v[i] = i * std::log(double(i));
  }
};
// Built at program start (before main, so no guard check in the scoring loops).
const NLogN kNLogN;
inline double nlogn(uint32_t n) {
  return n < uint32_t(kNLogNTable) ? kNLogN.v[n] : double(n) * std::log(double(n));
}

}  // namespace

double weighted_entropy(const uint32_t* counts, int count) {
  uint64_t n = 0;
  double s = 0;
  for (int i = 0; i < count; ++i) {
    n += counts[i];
    s += nlogn(counts[i]);
  }
  return nlogn(static_cast<uint32_t>(n)) - s;
}

double classification_objective(const uint32_t* left, const uint32_t* right, int count) {
  uint64_t n = 0;
  for (int i = 0; i < count; ++i) n += uint64_t(left[i]) + right[i];
  if (n == 0) return 0;
  return (weighted_entropy(left, count) + weighted_entropy(right, count)) / double(n);
}

double sum_squared_deviation(const JointOffsetStats* stats, int joints) {
  double s = 0;
  for (int j = 0; j < joints; ++j) {
    const JointOffsetStats& t = stats[j];
    if (t.n > 0) s += t.sq - (t.sx * t.sx + t.sy * t.sy + t.sz * t.sz) / t.n;
  }
  return s;
}

double regression_objective(const JointOffsetStats* left, const JointOffsetStats* right, int joints,
                            double left_pixels, double right_pixels) {
  const double n = left_pixels + right_pixels;
  if (n <= 0) return 0;
  return (sum_squared_deviation(left, joints) + sum_squared_deviation(right, joints)) / n;
}

OffsetProposal OffsetProposal::from_forest(const TrainedForest& forest) {
  OffsetProposal p;
  for (const TrainedTree& t : forest.trees)
    for (const TrainedNode& n : t.nodes) {
      if (n.is_leaf()) continue;
      p.first.push_back({n.du1, n.dv1});
      if (n.du2 != 0 || n.dv2 != 0) p.second.push_back({n.du2, n.dv2});
    }
  if (p.first.empty()) fail("proposal forest has no split nodes");
  return p;
}

namespace {

constexpr int kMaxThresholds = 255;  // padded search table of 256 entries
// Regression offsets are summed in fixed point with this many units per metre (2^12: 0.24 mm,
// below the 1 mm depth resolution). With ρ ≤ kMaxRhoM a pixel adds at most 3·(8·2^12)² = 3·2^30
// to a Σ|Δ|² sum, so 2^31 pixels (the most a tree takes) stay below 2^63: the int64 sums never wrap.
constexpr double kOffsetsPerMetre = 4096.0;
constexpr float kMaxRhoM = 8.0f;
constexpr int kBlock = kMaxThresholds;  // pixels of a node's threshold sample
// Upper bound on one work item's classification histogram cells (uint32): 256k = 1 MiB, so that a
// node's 400 candidates × 21 bins × up to 31 classes form one group and each pixel's probe
// neighbourhood is loaded once per node rather than once per group. A pixel's increments stay in
// its class's bins × lanes block (≤ 34 KiB). Measured with `TRAIN_BENCH_IMAGES=1000
// TRAIN_BENCH_PIXELS=300 TRAIN_BENCH_DEPTH=16 TRAIN_BENCH_OFFSETS=400 TRAIN_BENCH_THREADS=1
// bench_train`, 3 alternated runs each: 64k cells (256 KiB, L2-resident; ≤ 156 candidates per group
// at 20 classes) 1.73–1.80·10⁸ evaluations per CPU-second, 256k cells 2.01–2.14·10⁸ in two runs
// and 1.75·10⁸ in the third (levels 8–15: +25 % in the first two).
constexpr size_t kItemHistogramEntries = 262144;
// Pixels per range item at least, near the root (see grow_tree): enough that an item's fixed cost
// (zeroing and summing its partial histogram) stays small next to its feature evaluations.
constexpr uint32_t kMinRangePixels = 4096;
// Upper bound on the features a small node's work item keeps (int16, pixels × lanes): 256 KiB,
// half of this machine's 512 KiB L2 per core. A node whose pixels' features fit computes them
// once and takes its threshold sample's features from them (the sample's pixels are the node's),
// instead of evaluating the ≤ 255 sample pixels again: deep in a tree, where nodes hold 20–300
// pixels and the sample 20–50 of them, that is 10–100 % of the node's feature evaluations.
constexpr size_t kStoredFeatureBytes = 262144;
// Upper bound on a candidate group's histogram cells near the root: 256k = 1 MiB per range item;
// a pixel's increments stay within its class's bins × candidates block (≤ 64 KiB at 31 classes).
constexpr size_t kRangeHistogramEntries = 262144;

struct Candidate {
  int32_t du1, dv1, du2, dv2;
  int thresholds;                     // unique, sorted
  int32_t table[kMaxThresholds + 1];  // thresholds [0, thresholds)
};

// A node's threshold sample, decoded (structure of arrays).
struct Block {
  int count = 0;
  const uint16_t* image[kBlock];
  int32_t width[kBlock], height[kBlock], u[kBlock], v[kBlock], scale[kBlock];
  int32_t depth[kBlock];  // the pixel's own probe value
  int16_t feature[kBlock];  // |feature| ≤ 32766 fits int16
};

// probe_depth() without branches: off-image probes load element 0 and then select the background
// constant, so a mispredicted bounds check never flushes the many probe loads in flight.
inline int32_t probe_depth_select(const uint16_t* image, int32_t width, int32_t height, int32_t u, int32_t v) {
  const bool inside = (static_cast<uint32_t>(u) < static_cast<uint32_t>(width)) &
                      (static_cast<uint32_t>(v) < static_cast<uint32_t>(height));
  const int32_t value = image[inside ? v * width + u : 0];
  return inside ? value : kBackgroundDepthMm;
}

// Features of one candidate for a whole block (same values as dp::depth_feature). A separate loop
// without dependent work lets many probe loads be in flight at once. Unary candidates (δ2 = 0)
// read the pixel's own depth.
void block_features(Block& b, const Candidate& c) {
  if (c.du2 == 0 && c.dv2 == 0) {
    for (int i = 0; i < b.count; ++i) {
      const int32_t s = b.scale[i];
      const int32_t d1 = probe_depth_select(b.image[i], b.width[i], b.height[i], b.u[i] + probe_offset_px(c.du1, s),
                                            b.v[i] + probe_offset_px(c.dv1, s));
      b.feature[i] = static_cast<int16_t>(d1 - b.depth[i]);
    }
  } else {
    for (int i = 0; i < b.count; ++i) {
      const int32_t s = b.scale[i];
      const int32_t d1 = probe_depth_select(b.image[i], b.width[i], b.height[i], b.u[i] + probe_offset_px(c.du1, s),
                                            b.v[i] + probe_offset_px(c.dv1, s));
      const int32_t d2 = probe_depth_select(b.image[i], b.width[i], b.height[i], b.u[i] + probe_offset_px(c.du2, s),
                                            b.v[i] + probe_offset_px(c.dv2, s));
      b.feature[i] = static_cast<int16_t>(d1 - d2);
    }
  }
}

// One feature with the runtime's rule (used to partition pixels).
inline int32_t feature_of_pixel(const TrainingSet& set, const TrainingPixel& p, const Candidate& c) {
  const TrainingImage& im = set.images[p.image];
  return depth_feature(im.probe.data(), im.width, im.height, p.u, p.v, p.depth_mm, im.focal_factor, c.du1, c.dv1,
                       c.du2, c.dv2);
}

// The candidates of one work item in structure-of-arrays form for the pixel-major kernel: offsets
// per lane, thresholds transposed ([threshold][lane]) and padded with kNoThreshold (make_lanes:
// each column's unique thresholds in order, then padding; set_lane_thresholds: the sorted sample
// with repeats replaced by kNoThreshold; a bin counts the thresholds below a feature, the same in
// both), the count padded to a multiple of kLanes with inert lanes (zero offsets, no thresholds).
// Lanes hold the unary candidates (δ2 = 0) first, then the others, each part in candidate order:
// the AVX2 kernel reads the pixel's own depth instead of a second probe for every 8-lane block that
// is all unary (about half the candidates). lane[c] is candidate c's lane; kernels write bins by
// lane and histograms are indexed by lane, while scoring walks candidates in their order (ties:
// lowest).
constexpr int kLanes = 16;                    // int16 lanes of an AVX2 register
constexpr int16_t kNoThreshold = 32767;       // above every feature (|feature| ≤ 32766)
struct CandidateLanes {
  int count = 0, padded = 0, thresholds = 0;  // thresholds = rows of the table
  int unary = 0;                              // lanes [0, unary) are unary candidates
  std::vector<int32_t> du1, dv1, du2, dv2;
  std::vector<int16_t> table;                 // thresholds × padded
  std::vector<int32_t> lane;                  // per candidate
};

// The offset part of make_lanes: count, padded, unary, lane and the offset rows (what the
// feature kernels read); no thresholds.
void make_offset_lanes(const std::vector<Candidate>& candidates, CandidateLanes& l) {
  l.count = static_cast<int>(candidates.size());
  l.padded = (l.count + kLanes - 1) / kLanes * kLanes;
  l.thresholds = 0;
  l.unary = 0;
  for (const Candidate& c : candidates) l.unary += c.du2 == 0 && c.dv2 == 0;
  for (auto* v : {&l.du1, &l.dv1, &l.du2, &l.dv2}) v->assign(l.padded, 0);
  l.lane.resize(l.count);
  int next_unary = 0, next_binary = l.unary;
  for (int c = 0; c < l.count; ++c) {
    const Candidate& cand = candidates[c];
    const int k = cand.du2 == 0 && cand.dv2 == 0 ? next_unary++ : next_binary++;
    l.lane[c] = k;
    l.du1[k] = cand.du1;
    l.dv1[k] = cand.dv1;
    l.du2[k] = cand.du2;
    l.dv2[k] = cand.dv2;
  }
}

void make_lanes(const std::vector<Candidate>& candidates, CandidateLanes& l) {
  make_offset_lanes(candidates, l);
  for (const Candidate& c : candidates) l.thresholds = std::max(l.thresholds, c.thresholds);
  l.table.assign(size_t(l.thresholds) * l.padded, kNoThreshold);
  for (int c = 0; c < l.count; ++c) {
    const Candidate& cand = candidates[c];
    for (int t = 0; t < cand.thresholds; ++t)
      l.table[size_t(t) * l.padded + l.lane[c]] = static_cast<int16_t>(cand.table[t]);
  }
}

// A training image as the kernel reads it.
struct ImageRef {
  const uint16_t* probe;
  int32_t width, height;
};

// bin[c] = the number of lane c's thresholds below feature[c] (8 lanes per SSE2 instruction).
inline void bins_sse2(const CandidateLanes& l, const int16_t* feature, int16_t* bin) {
  for (int c = 0; c < l.padded; c += 8) {
    const __m128i f = _mm_loadu_si128(reinterpret_cast<const __m128i*>(feature + c));
    __m128i count = _mm_setzero_si128();
    const int16_t* t = l.table.data() + c;
    for (int k = 0; k < l.thresholds; ++k, t += l.padded)
      count = _mm_sub_epi16(count, _mm_cmpgt_epi16(f, _mm_loadu_si128(reinterpret_cast<const __m128i*>(t))));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(bin + c), count);
  }
}

// Features and bins of every candidate at one pixel (same values as dp::depth_feature and
// block_bins). Pixel-major: the pixel's neighbourhood stays in L1 while all candidates probe it,
// and consecutive pixels of a node mostly come from the same image (pixels stay in image order).
// A unary candidate (δ2 = 0) probes the pixel itself (offset 0 rounds to 0), which is its depth.
// Off-image probes load element 0 and OR in 0x7FFF: probe values are ≤ 32767, so the result is
// the background constant 32767 without a branch or select.
// Writes bin[0, l.padded); `feature` is scratch of l.padded entries. `l` is shared by threads
// (read only); feature and bin are the calling thread's.
inline void features_scalar(const CandidateLanes& l, const ImageRef& im, int32_t u, int32_t v, int32_t s,
                            int16_t* feature) {
  static_assert(kBackgroundDepthMm == 0x7FFF, "the OR trick needs the background to be all ones");
  const uint32_t w = static_cast<uint32_t>(im.width), h = static_cast<uint32_t>(im.height);
  for (int c = 0; c < l.padded; ++c) {
    const int32_t u1 = u + probe_offset_px(l.du1[c], s), v1 = v + probe_offset_px(l.dv1[c], s);
    const int32_t u2 = u + probe_offset_px(l.du2[c], s), v2 = v + probe_offset_px(l.dv2[c], s);
    const int32_t in1 = -int32_t((static_cast<uint32_t>(u1) < w) & (static_cast<uint32_t>(v1) < h));
    const int32_t in2 = -int32_t((static_cast<uint32_t>(u2) < w) & (static_cast<uint32_t>(v2) < h));
    const int32_t d1 = im.probe[(v1 * im.width + u1) & in1] | (~in1 & 0x7FFF);
    const int32_t d2 = im.probe[(v2 * im.width + u2) & in2] | (~in2 & 0x7FFF);
    feature[c] = static_cast<int16_t>(d1 - d2);
  }
}
inline void pixel_features(const CandidateLanes& l, const ImageRef& im, int32_t u, int32_t v, int32_t s,
                           int16_t* feature, int16_t* bin) {
  features_scalar(l, im, u, v, s, feature);
  bins_sse2(l, feature, bin);
}

// One probe for 8 lanes (offset rows du, dv) at a pixel: offsets, bounds and the element index
// with AVX2, then eight scalar loads. Off-image lanes load element 0 and OR in the background
// (0x7FFF, as pixel_features). Scalar loads rather than vpgatherdd: on this machine's Zen 3 cores
// the gather kernel measured 12–15 % slower on bench_train (same binary, alternated runs).
struct ProbeAvx2 {
  __m256i vs, vu, vv, w, w1, h1, half, background;
  const uint16_t* base;
};
// The element indices of one probe for 8 lanes (0 for off-image lanes, which `outside` marks).
__attribute__((target("avx2"), always_inline)) inline __m256i probe_index_avx2(const ProbeAvx2& q, const int32_t* du,
                                                                                const int32_t* dv, __m256i& outside) {
  const __m256i pu = _mm256_add_epi32(
      q.vu, _mm256_srai_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(du)), q.vs), q.half),
                kScaleShift));
  const __m256i pv = _mm256_add_epi32(
      q.vv, _mm256_srai_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(dv)), q.vs), q.half),
                kScaleShift));
  outside = _mm256_srai_epi32(
      _mm256_or_si256(_mm256_or_si256(pu, pv), _mm256_or_si256(_mm256_sub_epi32(q.w1, pu), _mm256_sub_epi32(q.h1, pv))), 31);
  return _mm256_andnot_si256(outside, _mm256_add_epi32(_mm256_mullo_epi32(pv, q.w), pu));
}
__attribute__((target("avx2"), always_inline)) inline __m256i probe_avx2(const ProbeAvx2& q, const int32_t* du,
                                                                          const int32_t* dv) {
  __m256i outside;
  alignas(32) int32_t at[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(at), probe_index_avx2(q, du, dv, outside));
  const uint16_t* p = q.base;
  const __m256i g = _mm256_setr_epi32(p[at[0]], p[at[1]], p[at[2]], p[at[3]], p[at[4]], p[at[5]], p[at[6]], p[at[7]]);
  return _mm256_or_si256(g, _mm256_and_si256(outside, q.background));
}

// bin[c] = the number of lane c's thresholds below feature[c], 16 lanes per instruction, with
// four independent counts so that the compare chain over the thresholds is a quarter as long.
__attribute__((target("avx2"), always_inline)) inline void bin_features(const CandidateLanes& l,
                                                                         const int16_t* feature, int16_t* bin) {
  const size_t stride = size_t(l.padded);
  for (int c = 0; c < l.padded; c += 16) {
    const __m256i f = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(feature + c));
    __m256i n0 = _mm256_setzero_si256(), n1 = n0, n2 = n0, n3 = n0;
    const int16_t* t = l.table.data() + c;
#define DP_BELOW(k) _mm256_cmpgt_epi16(f, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t + (k) * stride)))
    int k = 0;
    for (; k + 4 <= l.thresholds; k += 4) {
      n0 = _mm256_sub_epi16(n0, DP_BELOW(k));
      n1 = _mm256_sub_epi16(n1, DP_BELOW(k + 1));
      n2 = _mm256_sub_epi16(n2, DP_BELOW(k + 2));
      n3 = _mm256_sub_epi16(n3, DP_BELOW(k + 3));
    }
    for (; k < l.thresholds; ++k) n0 = _mm256_sub_epi16(n0, DP_BELOW(k));
#undef DP_BELOW
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(bin + c),
                        _mm256_add_epi16(_mm256_add_epi16(n0, n1), _mm256_add_epi16(n2, n3)));
  }
}

__attribute__((target("avx2"), always_inline)) inline ProbeAvx2 probe_setup_avx2(const ImageRef& im, int32_t u,
                                                                                   int32_t v, int32_t s) {
  ProbeAvx2 q;
  q.vs = _mm256_set1_epi32(s);
  q.vu = _mm256_set1_epi32(u);
  q.vv = _mm256_set1_epi32(v);
  q.w = _mm256_set1_epi32(im.width);
  q.w1 = _mm256_set1_epi32(im.width - 1);
  q.h1 = _mm256_set1_epi32(im.height - 1);
  q.half = _mm256_set1_epi32(kScaleOneQ13 >> 1);
  q.background = _mm256_set1_epi32(kBackgroundDepthMm);
  q.base = im.probe;
  return q;
}

// feature[lane] for every lane of `l` (its offsets only: thresholds are not read), 8 lanes per
// AVX2 instruction for the offsets and bounds (probe_avx2).
__attribute__((target("avx2"))) void features_avx2(const CandidateLanes& l, const ImageRef& im, int32_t u, int32_t v,
                                                   int32_t s, int16_t* feature) {
  const ProbeAvx2 q = probe_setup_avx2(im, u, v, s);
  // A unary lane's second probe is at offset 0: the pixel itself, always inside the image.
  const __m256i own = _mm256_set1_epi32(im.probe[v * im.width + u]);
  // Two loops: the features of every lane first, then the bins. Each block's chain (offsets →
  // index → loads → feature → 20 compares) is longer than the out-of-order window holds; split,
  // the loads of consecutive blocks overlap, and so do the compare chains.
  for (int c = 0; c < l.padded; c += 16) {
    const __m256i f0 = _mm256_sub_epi32(probe_avx2(q, &l.du1[c], &l.dv1[c]),
                                        c + 8 <= l.unary ? own : probe_avx2(q, &l.du2[c], &l.dv2[c]));
    const __m256i f1 = _mm256_sub_epi32(probe_avx2(q, &l.du1[c + 8], &l.dv1[c + 8]),
                                        c + 16 <= l.unary ? own : probe_avx2(q, &l.du2[c + 8], &l.dv2[c + 8]));
    // packs interleaves 128-bit halves: [f0 0-3, f1 0-3, f0 4-7, f1 4-7] → reorder the quadwords.
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(feature + c),
                        _mm256_permute4x64_epi64(_mm256_packs_epi32(f0, f1), 0xD8));
  }
}
// bin_features for a non-inlined caller.
__attribute__((target("avx2"))) void bins_avx2(const CandidateLanes& l, const int16_t* feature, int16_t* bin) {
  bin_features(l, feature, bin);
}
// The same as pixel_features: features_avx2, then bin_features (16 lanes per instruction).
__attribute__((target("avx2"))) void pixel_features_avx2(const CandidateLanes& l, const ImageRef& im, int32_t u,
                                                         int32_t v, int32_t s, int16_t* feature, int16_t* bin) {
  features_avx2(l, im, u, v, s, feature);
  bin_features(l, feature, bin);
}

// The AVX-512 kernels (x86-64 CPUs with AVX-512 F, BW, VL and DQ): the same values as
// features_avx2 and bin_features, 16 probes per instruction. Probes are vpgatherdd of 32-bit words
// at the 16-bit elements' addresses, masked to the low half (little endian: the element itself); a
// word at the last element reads two bytes past it, which is why the Grower's ImageRefs have
// kProbePadding elements after the crop.
// Off-image lanes are masked out of the gather (no load) and keep the background value.
#define DP_AVX512 __attribute__((target("avx512f,avx512bw,avx512vl,avx512dq")))
// (The maskz forms with all lanes set: the plain intrinsics leave GCC 12 warning about their
// undefined source operand.)
constexpr __mmask16 kAll16 = 0xFFFF;
struct ProbeAvx512 {
  __m512i vs, vu, vv, w, h, half, background, low;
  const void* base;
};
// One probe for 16 lanes (offset rows du, dv) at the pixel of q.
DP_AVX512 __attribute__((always_inline)) inline __m512i probe_avx512(const ProbeAvx512& q, const int32_t* du,
                                                                    const int32_t* dv) {
  const __m512i pu = _mm512_add_epi32(
      q.vu, _mm512_maskz_srai_epi32(kAll16, _mm512_add_epi32(_mm512_madd_epi16(_mm512_loadu_si512(du), q.vs), q.half),
                                    kScaleShift));
  const __m512i pv = _mm512_add_epi32(
      q.vv, _mm512_maskz_srai_epi32(kAll16, _mm512_add_epi32(_mm512_madd_epi16(_mm512_loadu_si512(dv), q.vs), q.half),
                                    kScaleShift));
  const __mmask16 inside = _mm512_cmplt_epu32_mask(pu, q.w) & _mm512_cmplt_epu32_mask(pv, q.h);
  const __m512i index = _mm512_add_epi32(_mm512_mullo_epi32(pv, q.w), pu);
  return _mm512_and_si512(_mm512_mask_i32gather_epi32(q.background, inside, index, q.base, 2), q.low);
}
DP_AVX512 void features_avx512(const CandidateLanes& l, const ImageRef& im, int32_t u, int32_t v, int32_t s,
                               int16_t* feature) {
  ProbeAvx512 q;
  q.vs = _mm512_set1_epi32(s);
  q.vu = _mm512_set1_epi32(u);
  q.vv = _mm512_set1_epi32(v);
  q.w = _mm512_set1_epi32(im.width);
  q.h = _mm512_set1_epi32(im.height);
  q.half = _mm512_set1_epi32(kScaleOneQ13 >> 1);
  q.background = _mm512_set1_epi32(kBackgroundDepthMm);
  q.low = _mm512_set1_epi32(0xFFFF);
  q.base = im.probe;
  const __m512i own = _mm512_set1_epi32(im.probe[v * im.width + u]);
  for (int c = 0; c < l.padded; c += 16) {
    const __m512i f = _mm512_sub_epi32(probe_avx512(q, &l.du1[c], &l.dv1[c]),
                                       c + 16 <= l.unary ? own : probe_avx512(q, &l.du2[c], &l.dv2[c]));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(feature + c), _mm512_maskz_cvtsepi32_epi16(kAll16, f));
  }
}
// bin[c] = the number of lane c's thresholds below feature[c], 32 lanes per instruction (the
// last 16 of a count that is not a multiple of 32 with 256-bit registers).
DP_AVX512 void bins_avx512(const CandidateLanes& l, const int16_t* feature, int16_t* bin) {
  const size_t stride = size_t(l.padded);
  int c = 0;
  const __m512i one = _mm512_set1_epi16(1);
  for (; c + 32 <= l.padded; c += 32) {
    const __m512i f = _mm512_loadu_si512(feature + c);
    __m512i n0 = _mm512_setzero_si512(), n1 = n0, n2 = n0, n3 = n0;
    const int16_t* t = l.table.data() + c;
#define DP_COUNT(n, k) n = _mm512_mask_add_epi16(n, _mm512_cmpgt_epi16_mask(f, _mm512_loadu_si512(t + (k) * stride)), n, one)
    int k = 0;
    for (; k + 4 <= l.thresholds; k += 4) {
      DP_COUNT(n0, k);
      DP_COUNT(n1, k + 1);
      DP_COUNT(n2, k + 2);
      DP_COUNT(n3, k + 3);
    }
    for (; k < l.thresholds; ++k) DP_COUNT(n0, k);
#undef DP_COUNT
    _mm512_storeu_si512(bin + c, _mm512_add_epi16(_mm512_add_epi16(n0, n1), _mm512_add_epi16(n2, n3)));
  }
  if (c < l.padded) {
    const __m256i f = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(feature + c));
    __m256i n = _mm256_setzero_si256();
    const __m256i one8 = _mm256_set1_epi16(1);
    const int16_t* t = l.table.data() + c;
    for (int k = 0; k < l.thresholds; ++k)
      n = _mm256_mask_add_epi16(n, _mm256_cmpgt_epi16_mask(f, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t + k * stride))), n, one8);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(bin + c), n);
  }
}
// cell[c] = bin[c] × nc + c for c < nc (rounded up to 16): a classification pixel's histogram
// cells within its class's block (count_pixel), 16 per instruction.
DP_AVX512 void cells_avx512(const int16_t* bin, int nc, int32_t* cell) {
  const __m512i vnc = _mm512_set1_epi32(nc), step = _mm512_set1_epi32(16);
  __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  for (int c = 0; c < nc; c += 16, lane = _mm512_add_epi32(lane, step)) {
    const __m512i b = _mm512_maskz_cvtepi16_epi32(kAll16, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(bin + c)));
    _mm512_storeu_si512(cell + c, _mm512_add_epi32(_mm512_mullo_epi32(b, vnc), lane));
  }
}
DP_AVX512 void pixel_features_avx512(const CandidateLanes& l, const ImageRef& im, int32_t u, int32_t v, int32_t s,
                                     int16_t* feature, int16_t* bin) {
  features_avx512(l, im, u, v, s, feature);
  bins_avx512(l, feature, bin);
}

using PixelFeaturesFn = void (*)(const CandidateLanes&, const ImageRef&, int32_t, int32_t, int32_t, int16_t*, int16_t*);
using RowFeaturesFn = void (*)(const CandidateLanes&, const ImageRef&, int32_t, int32_t, int32_t, int16_t*);
using RowBinsFn = void (*)(const CandidateLanes&, const int16_t*, int16_t*);
// The kernels a Grower uses, chosen once per process from the CPU: AVX-512 (F, BW, VL, DQ), else
// AVX2, else the portable ones (row = nullptr: candidate groups then go through block_features);
// the same results (integer arithmetic throughout).
// DEPTHPOSE_TRAIN_NO_AVX512=1 skips the first, DEPTHPOSE_TRAIN_NO_AVX2=1 both (tests compare the
// forests of all three).
struct TrainKernels {
  PixelFeaturesFn pixel = pixel_features;  // features and bins of one pixel
  RowFeaturesFn row = nullptr;             // features only (vector kernels)
  RowBinsFn bins = nullptr;                // bins of stored features (vector kernels)
  void (*cells)(const int16_t*, int, int32_t*) = nullptr;  // count_pixel's cell indices (AVX-512)
};
TrainKernels pick_kernels();
}  // namespace

const char* training_kernel_name() {
  const TrainKernels k = pick_kernels();
  return k.pixel == pixel_features_avx512 ? "avx512" : k.pixel == pixel_features_avx2 ? "avx2" : "portable";
}

namespace {
TrainKernels pick_kernels() {
  TrainKernels k;
  if (std::getenv("DEPTHPOSE_TRAIN_NO_AVX2") != nullptr || !__builtin_cpu_supports("avx2")) return k;
  if (std::getenv("DEPTHPOSE_TRAIN_NO_AVX512") == nullptr && __builtin_cpu_supports("avx512f") &&
      __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq"))
    return {pixel_features_avx512, features_avx512, bins_avx512, cells_avx512};
  return {pixel_features_avx2, features_avx2, bins_avx2};
}

// Classification scores (Eq. 7 with Eq. 8, the objective score_group minimizes) of four adjacent
// lanes [lane, lane + 4) of a group histogram (cells [class][bin][lane], `lanes_per_row` lanes per
// bin row) at thresholds t < thresholds: out[(lane + i) × bins + t], +∞ where score_group skips
// the threshold (nothing left of it, nothing right of it, or an empty bin). Every lane runs the
// scalar code's operations in its order — nlogn(left) − Σ_j nlogn(left_j), the same for the right,
// (wl + wr) / n, no fused multiply-add — so the scores are bit-identical; four lanes per
// instruction and no branch per class; a threshold that all four lanes skip costs only its
// counts. Needs n < kNLogNTable (every count is a table lookup).
// nlogn of four counts < kNLogNTable. (The masked form with an explicit source: the plain
// _mm256_i32gather_pd leaves GCC 12 warning about its undefined source operand.)
__attribute__((target("avx2"), always_inline)) inline __m256d nlogn4(__m128i counts) {
  return _mm256_mask_i32gather_pd(_mm256_setzero_pd(), kNLogN.v, counts,
                                  _mm256_castsi256_pd(_mm256_set1_epi64x(-1)), 8);
}
__attribute__((target("avx2"))) void score_lanes_avx2(const uint32_t* counts, int classes, int bins, int lanes_per_row,
                                                      int lane, int thresholds, const uint32_t* totals, uint32_t n,
                                                      double* out) {
  __m128i cum[256];
  for (int j = 0; j < classes; ++j) cum[j] = _mm_setzero_si128();
  __m128i left = _mm_setzero_si128();
  const __m128i all = _mm_set1_epi32(static_cast<int32_t>(n)), zero = _mm_setzero_si128();
  const __m256d vn = _mm256_set1_pd(double(n)), skipped = _mm256_set1_pd(HUGE_VAL);
  alignas(32) double score[4];
  for (int t = 0; t < thresholds; ++t) {
    __m128i in_bin = _mm_setzero_si128();
    for (int j = 0; j < classes; ++j) {
      const __m128i cell = _mm_loadu_si128(
          reinterpret_cast<const __m128i*>(counts + (size_t(j) * bins + t) * lanes_per_row + lane));
      cum[j] = _mm_add_epi32(cum[j], cell);
      in_bin = _mm_add_epi32(in_bin, cell);
    }
    left = _mm_add_epi32(left, in_bin);
    const __m128i right = _mm_sub_epi32(all, left);
    const __m128i skip = _mm_or_si128(_mm_or_si128(_mm_cmpeq_epi32(left, zero), _mm_cmpeq_epi32(right, zero)),
                                      _mm_cmpeq_epi32(in_bin, zero));
    if (_mm_movemask_ps(_mm_castsi128_ps(skip)) == 0xF) {
      // All four skipped (deep nodes: few pixels, so most bins of most lanes are empty).
      for (int i = 0; i < 4; ++i) out[size_t(lane + i) * bins + t] = HUGE_VAL;
      continue;
    }
    __m256d wl = nlogn4(left), wr = nlogn4(right);
    for (int j = 0; j < classes; ++j) {
      wl = _mm256_sub_pd(wl, nlogn4(cum[j]));
      wr = _mm256_sub_pd(wr, nlogn4(_mm_sub_epi32(_mm_set1_epi32(int32_t(totals[j])), cum[j])));
    }
    _mm256_store_pd(score, _mm256_blendv_pd(_mm256_div_pd(_mm256_add_pd(wl, wr), vn), skipped,
                                            _mm256_castsi256_pd(_mm256_cvtepi32_epi64(skip))));
    for (int i = 0; i < 4; ++i) out[size_t(lane + i) * bins + t] = score[i];
  }
}

// Batcher's odd–even merge sort network for n elements as comparator pairs (lower, higher index)
// after network[0] = n. Generated for n rounded up to a power of two with the missing elements
// taken as +∞: a comparator touching one of them never moves anything and is left out.
void batcher_network(int n, std::vector<uint16_t>& network) {
  if (!network.empty() && network[0] == n) return;
  network.assign(1, static_cast<uint16_t>(n));
  for (int p = 1; p < n; p <<= 1)
    for (int k = p; k >= 1; k >>= 1)
      for (int j = k % p; j + k < n; j += 2 * k)
        for (int i = 0; i < std::min(k, n - j - k); ++i)
          if ((i + j) / (2 * p) == (i + j + k) / (2 * p)) {
            network.push_back(static_cast<uint16_t>(i + j));
            network.push_back(static_cast<uint16_t>(i + j + k));
          }
}

__attribute__((target("avx2"))) void sort_columns_avx2(int16_t* rows, size_t stride, int lanes,
                                                       const std::vector<uint16_t>& network) {
  // Comparator-major: the 16-lane blocks of one comparator are independent of each other.
  for (size_t k = 1; k + 1 < network.size(); k += 2) {
    int16_t* a = rows + network[k] * stride;
    int16_t* b = rows + network[k + 1] * stride;
    for (int c = 0; c < lanes; c += 16) {
      const __m256i x = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a + c));
      const __m256i y = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b + c));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(a + c), _mm256_min_epi16(x, y));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(b + c), _mm256_max_epi16(x, y));
    }
  }
}

// table = rows (n × padded, each column sorted) with every value equal to the one above it
// replaced by kNoThreshold: the SIMD threshold table of set_lane_thresholds.
__attribute__((target("avx2"))) void mark_repeats_avx2(const int16_t* rows, int n, size_t padded, int16_t* table) {
  std::memcpy(table, rows, padded * sizeof(int16_t));
  const __m256i none = _mm256_set1_epi16(kNoThreshold);
  for (size_t i = padded; i < size_t(n) * padded; i += 16) {
    const __m256i value = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rows + i));
    const __m256i above = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rows + i - padded));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(table + i),
                        _mm256_blendv_epi8(value, none, _mm256_cmpeq_epi16(value, above)));
  }
}

struct NodeInfo {
  uint32_t heap = 0;
  uint32_t begin = 0, end = 0;  // this process's pixels of the node
  uint32_t count = 0;           // the node's pixels over all ranks (= end − begin in one process)
  uint32_t first = 0;           // position of this rank's first pixel in the node's global order
  int level = 0;
  bool splittable = false;
  double parent_score = 0;      // objective of not splitting (same normalization as Eq. 7)
  int classes = 0;              // classification: labels present
  uint8_t class_of[256];        // label → compact class
  std::vector<uint32_t> totals; // classification: count per compact class
};

struct Best {
  double score = HUGE_VAL;
  int candidate = -1;
  int32_t du1 = 0, dv1 = 0, du2 = 0, dv2 = 0, threshold = 0;
  // Keeps (candidate `index`, its threshold t) when its score is strictly lower: ties keep the
  // earlier candidate and threshold, in the scan order of the callers.
  void consider(double candidate_score, int index, const Candidate& c, int t) {
    if (!(candidate_score < score)) return;
    score = candidate_score;
    candidate = index;
    du1 = c.du1;
    dv1 = c.dv1;
    du2 = c.du2;
    dv2 = c.dv2;
    threshold = c.table[t];
  }
};

// score_group's scratch: running class counts (scalar lanes) and the scores by lane and threshold.
struct ScoreScratch {
  std::vector<uint32_t> cum;
  std::vector<double> scores;
};

struct Scratch {
  Block sample{};
  std::vector<Candidate> candidates;
  CandidateLanes lanes;
  std::vector<int16_t> feature, bin;  // one pixel's features and bins per lane (pixel_features)
  std::vector<int32_t> cell;          // one pixel's histogram cells per lane (count_pixel)
  std::vector<int16_t> sample_features;  // threshold sample × lanes (prepare_group)
  std::vector<int16_t> node_features;    // a small node's pixels × lanes (prepare_stored_group)
  std::vector<uint16_t> network;         // sort_int16_columns' comparators
  std::vector<int> unique_of_lane;       // set_lane_thresholds: thresholds so far per lane
  std::vector<int32_t*> table_of_lane;   // set_lane_thresholds: the lane's Candidate::table
  std::vector<uint32_t> counts;   // classification histograms
  std::vector<int64_t> sums;      // regression histograms (fixed point, pixel_offsets)
  std::vector<int32_t> offsets;   // regression: one pixel's joints × {w, dx, dy, dz}
  ScoreScratch score;
  std::vector<JointOffsetStats> left, right, total;
};

class Grower {
 public:
  struct CandidateGroup;
  Grower(const TrainingSet& set, std::vector<TrainingPixel>& pixels, int tree, const TreeParams& params)
      : set_(set), px_(pixels), tree_(tree), p_(params) {
    joints_ = static_cast<int>(set.joint_names.size());
    chunk_ = p_.objective == Objective::kClassification ? 16 : 4;
    kernels_ = pick_kernels();
    images_.reserve(set.images.size());
    for (const TrainingImage& im : set.images) {
      // The AVX-512 kernel reads kProbePadding elements past the crop (TrainingImage): images
      // built without them (by hand, in tests) are read from a padded copy.
      const size_t cells = size_t(im.width) * im.height;
      const uint16_t* probe = im.probe.data();
      if (!im.probe.empty() && im.probe.size() < cells + kProbePadding) {
        padded_probes_.emplace_back(im.probe);
        padded_probes_.back().resize(cells + kProbePadding, kBackgroundDepthMm);
        probe = padded_probes_.back().data();
      }
      images_.push_back({probe, im.width, im.height});
    }
    scratch_.resize(std::max(1, p_.threads));
    groups_.resize(std::max(1, p_.threads));
  }

  // Regression offsets of one pixel in fixed point (kOffsetQuantumM): per joint w (1 when |Δ| < ρ,
  // else 0) and w·Δx, w·Δy, w·Δz rounded to the quantum. Integer sums of these are exact in any
  // order, so partial sums over pixel ranges, threads or ranks add up to the same bits.
  void pixel_offsets(const TrainingPixel& p, int32_t* out) const {
    const TrainingImage& im = set_.images[p.image];
    const std::array<float, 3> x = pixel_point(im, p.u, p.v, p.depth_mm);
    const float rho2 = p_.rho_m * p_.rho_m;
    for (int j = 0; j < joints_; ++j) {
      const float dx = im.joints[3 * j] - x[0], dy = im.joints[3 * j + 1] - x[1], dz = im.joints[3 * j + 2] - x[2];
      const bool inside = dx * dx + dy * dy + dz * dz < rho2;
      out[4 * j] = inside;
      out[4 * j + 1] = inside ? static_cast<int32_t>(std::lrint(double(dx) * kOffsetsPerMetre)) : 0;
      out[4 * j + 2] = inside ? static_cast<int32_t>(std::lrint(double(dy) * kOffsetsPerMetre)) : 0;
      out[4 * j + 3] = inside ? static_cast<int32_t>(std::lrint(double(dz) * kOffsetsPerMetre)) : 0;
    }
  }
  // Adds one pixel's offsets (pixel_offsets) to per-joint sums {n, Σx, Σy, Σz, Σ|Δ|²}.
  static void add_offsets(const int32_t* o, int joints, int64_t* sums) {
    for (int j = 0; j < joints; ++j, o += 4, sums += 5) {
      sums[0] += o[0];
      sums[1] += o[1];
      sums[2] += o[2];
      sums[3] += o[3];
      sums[4] += int64_t(o[1]) * o[1] + int64_t(o[2]) * o[2] + int64_t(o[3]) * o[3];
    }
  }
  // Fixed-point per-joint sums → statistics in metres.
  static JointOffsetStats stats_of(const int64_t* s) {
    const double q = 1.0 / kOffsetsPerMetre;
    return {double(s[0]), double(s[1]) * q, double(s[2]) * q, double(s[3]) * q, double(s[4]) * q * q};
  }

  // Per-node statistics of this process's pixels: `labels` (256 counts, classification) or
  // `sums` (joints × 5 fixed-point sums, regression). Summed over ranks they give finish()'s input.
  bool classification() const { return p_.objective == Objective::kClassification; }
  int stats_sums() const { return p_.objective == Objective::kClassification ? 0 : joints_ * 5; }
  void local_stats(const NodeInfo& node, uint32_t* labels, int64_t* sums) const {
    if (p_.objective == Objective::kClassification) {
      std::fill(labels, labels + 256, 0u);
      for (uint32_t i = node.begin; i < node.end; ++i) ++labels[px_[i].label];
    } else {
      std::fill(sums, sums + stats_sums(), int64_t(0));
      std::vector<int32_t> o(4 * joints_);
      for (uint32_t i = node.begin; i < node.end; ++i) {
        pixel_offsets(px_[i], o.data());
        add_offsets(o.data(), joints_, sums);
      }
    }
  }
  // Sets the node's objective before splitting and whether to search it, from its statistics
  // over all its `count` pixels.
  void finish(NodeInfo& node, uint32_t count, const uint32_t* labels, const int64_t* sums) const {
    node.count = count;
    const uint32_t n = count;
    if (p_.objective == Objective::kClassification) {
      node.classes = 0;
      node.totals.clear();
      for (int l = 0; l < 256; ++l) {
        node.class_of[l] = 0;
        if (labels[l]) {
          node.class_of[l] = static_cast<uint8_t>(node.classes++);
          node.totals.push_back(labels[l]);
        }
      }
      node.parent_score = n ? weighted_entropy(node.totals.data(), node.classes) / n : 0;
      node.splittable = node.classes > 1;
    } else {
      std::vector<JointOffsetStats> st(joints_);
      for (int j = 0; j < joints_; ++j) st[j] = stats_of(sums + 5 * j);
      node.parent_score = n ? sum_squared_deviation(st.data(), joints_) / n : 0;
      node.splittable = node.parent_score > 1e-12;
    }
    node.splittable = node.splittable && node.level < p_.max_depth && n >= uint32_t(std::max(2, p_.min_samples));
  }

  void prepare(NodeInfo& node) const {
    uint32_t labels[256];
    std::vector<int64_t> sums(stats_sums());
    local_stats(node, labels, sums.data());
    node.first = 0;
    finish(node, node.end - node.begin, labels, sums.data());
  }

  // The positions (in the node's global pixel order) of the node's threshold sample:
  // min(n, |thresholds|) pixels drawn with replacement (key: seed, tree, node), shared by all
  // candidates of the node.
  int sample_positions(const NodeInfo& node, uint32_t* positions) const {
    Rng rng = Rng::keyed(p_.seed, 5, uint64_t(tree_), node.heap);
    const uint32_t n = node.count;
    const int count = static_cast<int>(std::min<uint32_t>(n, std::min(p_.threshold_candidates, kMaxThresholds)));
    for (int i = 0; i < count; ++i) positions[i] = static_cast<uint32_t>(rng.below(n));
    return count;
  }
  // Decodes the sample positions that this process holds ([first, first + end − begin)) into `b`;
  // `slots` receives each decoded pixel's index in the sample.
  void decode_owned(const NodeInfo& node, const uint32_t* positions, int count, Block& b, int* slots) const {
    b.count = 0;
    for (int i = 0; i < count; ++i) {
      if (positions[i] < node.first || positions[i] - node.first >= node.end - node.begin) continue;
      const TrainingPixel& p = px_[node.begin + (positions[i] - node.first)];
      const ImageRef& im = images_[p.image];
      const int k = b.count++;
      slots[k] = i;
      b.image[k] = im.probe;
      b.width[k] = im.width;
      b.height[k] = im.height;
      b.u[k] = p.u;
      b.v[k] = p.v;
      b.scale[k] = p.scale_q13;
      b.depth[k] = p.depth_mm;
    }
  }

  // The node's threshold sample, decoded (all of it is in this process).
  void decode_sample(const NodeInfo& node, Block& b) const {
    uint32_t positions[kBlock];
    int slots[kBlock];
    decode_owned(node, positions, sample_positions(node, positions), b, slots);
  }

  // Offsets of candidate `index` of `node` (key: seed, tree, node, index).
  void draw_offsets(const NodeInfo& node, int index, Candidate& c) const {
    Rng rng = Rng::keyed(p_.seed, 3, uint64_t(tree_), node.heap, uint64_t(index));
    const int m = p_.max_offset_pxm;
    auto draw = [&](const std::vector<std::array<int16_t, 2>>& chosen, int32_t& du, int32_t& dv) {
      if (p_.proposal && !chosen.empty() && rng.unit() >= p_.proposal->uniform_fraction) {
        const auto& o = chosen[rng.below(chosen.size())];
        const int j = p_.proposal->jitter_pxm;
        du = std::clamp<int32_t>(o[0] + rng.range(-j, j), -m, m);
        dv = std::clamp<int32_t>(o[1] + rng.range(-j, j), -m, m);
      } else {
        du = rng.range(-m, m);
        dv = rng.range(-m, m);
      }
    };
    draw(p_.proposal ? p_.proposal->first : std::vector<std::array<int16_t, 2>>{}, c.du1, c.dv1);
    if (rng.unit() < 0.5) {
      c.du2 = c.dv2 = 0;
    } else {
      draw(p_.proposal ? p_.proposal->second : std::vector<std::array<int16_t, 2>>{}, c.du2, c.dv2);
    }
  }
  // Thresholds: the feature's values at the node's sample pixels (its response distribution).
  static void set_thresholds(Candidate& c, const int16_t* sample_features, int count) {
    for (int i = 0; i < count; ++i) c.table[i] = sample_features[i];
    std::sort(c.table, c.table + count);
    c.thresholds = static_cast<int>(std::unique(c.table, c.table + count) - c.table);
  }
  // The thresholds of every candidate of `g` (offset lanes made) from its threshold sample's
  // features, `rows` = n × padded (row i: sample pixel i, by lane), which it overwrites: the
  // columns are sorted together (sort_int16_columns) instead of one std::sort per candidate (deep
  // in a tree that sort cost a fifth of a level). Each candidate's sorted unique values are what
  // set_thresholds gives; the SIMD table is the sorted columns with every repeated value replaced
  // by kNoThreshold. Binning counts the thresholds below a feature, which does not depend on their
  // order, so a value's copies and the padding count nothing and a bin is the value's rank among
  // the unique thresholds, as with make_lanes.
  // The inert lanes' columns are set to kNoThreshold first, so they bin nothing.
  void set_lane_thresholds(CandidateGroup& g, int16_t* rows, int n, int thread) {
    CandidateLanes& l = g.lanes;
    Scratch& s = scratch_[thread];
    const size_t padded = size_t(l.padded);
    for (int t = 0; t < n; ++t)
      for (size_t k = size_t(l.count); k < padded; ++k) rows[t * padded + k] = kNoThreshold;
    sort_int16_columns(rows, n, padded, l.padded, s.network);
    l.thresholds = n;
    l.table.resize(size_t(n) * padded);
    mark_repeats_avx2(rows, n, padded, l.table.data());
    // Each candidate's unique values in order: row by row, all lanes at once, without a branch
    // (one per value mispredicted half the time and cost a tenth of a deep level).
    s.unique_of_lane.assign(padded, 0);
    s.table_of_lane.resize(padded);
    for (int c = 0; c < l.count; ++c) s.table_of_lane[l.lane[c]] = g.candidates[c].table;
    int* unique = s.unique_of_lane.data();
    int32_t* const* out = s.table_of_lane.data();
    for (int t = 0; t < n; ++t) {
      const int16_t* row = l.table.data() + t * padded;
      for (int k = 0; k < l.count; ++k) {
        out[k][unique[k]] = row[k];
        unique[k] += row[k] != kNoThreshold;
      }
    }
    g.bins = 1;
    for (int c = 0; c < l.count; ++c) {
      g.candidates[c].thresholds = unique[l.lane[c]];
      g.bins = std::max(g.bins, unique[l.lane[c]] + 1);
    }
  }
  void make_candidate(const NodeInfo& node, int index, Block& sample, Candidate& c) const {
    draw_offsets(node, index, c);
    block_features(sample, c);
    set_thresholds(c, sample.feature, sample.count);
  }

  // Candidates [c0, c1) of `node`, prepared once (offsets, thresholds, SIMD lanes) and shared by
  // the work items that accumulate their histograms over parts of the node's pixels.
  struct CandidateGroup {
    int c0 = 0, c1 = 0, bins = 1;
    std::vector<Candidate> candidates;
    CandidateLanes lanes;
    size_t histogram_cells(const NodeInfo& node) const { return size_t(node.classes) * bins * (c1 - c0); }
  };

  void prepare_group(const NodeInfo& node, int c0, int c1, CandidateGroup& g, int thread) {
    Scratch& s = scratch_[thread];
    g.c0 = c0;
    g.c1 = c1;
    g.candidates.resize(c1 - c0);
    decode_sample(node, s.sample);
    if (!kernels_.row) {
      for (int c = 0; c < c1 - c0; ++c) make_candidate(node, c0 + c, s.sample, g.candidates[c]);
      finish_group(g);
      return;
    }
    // With AVX2 the sample's features come from the pixel-major kernel (the same values as
    // block_features): a node of ~100 pixels spends as much on its ≤ 255-pixel sample as on
    // its pixels, so the sample gets the fast kernel too.
    for (int c = 0; c < c1 - c0; ++c) draw_offsets(node, c0 + c, g.candidates[c]);
    make_offset_lanes(g.candidates, g.lanes);
    const size_t padded = size_t(g.lanes.padded);
    const int n = s.sample.count;
    s.sample_features.resize(n * padded);
    for (int i = 0; i < n; ++i)
      kernels_.row(g.lanes, {s.sample.image[i], s.sample.width[i], s.sample.height[i]}, s.sample.u[i], s.sample.v[i],
                    s.sample.scale[i], s.sample_features.data() + i * padded);
    set_lane_thresholds(g, s.sample_features.data(), n, thread);
  }
  // Whether prepare_stored_group applies to candidates [c0, c1) of `node`: the AVX2 kernel, all of
  // the node's pixels in this process, and their features within kStoredFeatureBytes.
  bool stores_features(const NodeInfo& node, int c0, int c1) const {
    const size_t padded = size_t(c1 - c0 + kLanes - 1) / kLanes * kLanes;
    return kernels_.row && node.first == 0 && node.count == node.end - node.begin &&
           size_t(node.count) * padded * sizeof(int16_t) <= kStoredFeatureBytes;
  }
  // The same group as prepare_group, for a node where stores_features(): the features of all the
  // node's pixels go to the thread's node_features (pixel-major, l.padded per pixel) and the
  // threshold sample's features are read from there (same pixels, same kernel, same values).
  // Returns node_features for accumulate.
  const int16_t* prepare_stored_group(const NodeInfo& node, int c0, int c1, CandidateGroup& g, int thread) {
    Scratch& s = scratch_[thread];
    draw_group(node, c0, c1, g);
    s.node_features.resize(size_t(node.count) * g.lanes.padded);
    feature_rows(g, node.begin, node.end, s.node_features.data());
    thresholds_from_rows(node, s.node_features.data(), g, thread);
    return s.node_features.data();
  }
  // Candidates [c0, c1) of `node` drawn into g, with their offset lanes (no thresholds yet).
  void draw_group(const NodeInfo& node, int c0, int c1, CandidateGroup& g) const {
    g.c0 = c0;
    g.c1 = c1;
    g.candidates.resize(c1 - c0);
    for (int c = 0; c < c1 - c0; ++c) draw_offsets(node, c0 + c, g.candidates[c]);
    make_offset_lanes(g.candidates, g.lanes);
  }
  // The features of every lane of `l` at pixel i (the AVX2 kernel, or the portable one), into
  // row[0, l.padded).
  void pixel_feature_row(const CandidateLanes& l, uint32_t i, int16_t* row) const {
    const TrainingPixel& p = px_[i];
    if (kernels_.row)
      kernels_.row(l, images_[p.image], p.u, p.v, p.scale_q13, row);
    else
      features_scalar(l, images_[p.image], p.u, p.v, p.scale_q13, row);
  }
  bool has_vector_kernel() const { return kernels_.row != nullptr; }
  // The offset lanes of all candidates of `node` (what pixel_feature_row reads), drawn by draw_group
  // in the thread's group and copied out.
  void offset_lanes(const NodeInfo& node, CandidateLanes& l, int thread) {
    draw_group(node, 0, p_.offset_candidates, groups_[thread]);
    l = groups_[thread].lanes;
  }
  uint32_t image_of(uint32_t i) const { return px_[i].image; }
  size_t image_count() const { return images_.size(); }
  // evaluate() for a node whose pixels' features for all candidates (lanes of
  // draw_group(node, 0, offset_candidates)) are already in `rows`, pixel-major.
  Best evaluate_rows(const NodeInfo& node, const int16_t* rows, int thread) {
    CandidateGroup& g = groups_[thread];
    draw_group(node, 0, p_.offset_candidates, g);
    thresholds_from_rows(node, rows, g, thread);
    return search_group(node, g, rows, thread);
  }
  // The features of g's lanes (offsets only) at this process's pixels [begin, end), pixel-major:
  // pixel i's at rows + (i − begin) × g.lanes.padded.
  void feature_rows(const CandidateGroup& g, uint32_t begin, uint32_t end, int16_t* rows) const {
    const size_t padded = size_t(g.lanes.padded);
    for (uint32_t i = begin; i < end; ++i) pixel_feature_row(g.lanes, i, rows + (i - begin) * padded);
  }
  // The thresholds of g (draw_group done) from `rows`, the features of all the node's pixels in
  // its global order (pixel-major, g.lanes.padded per pixel): the threshold sample's features are
  // the rows at the sample positions (the same values prepare_group computes from the pixels).
  void thresholds_from_rows(const NodeInfo& node, const int16_t* rows, CandidateGroup& g, int thread) {
    Scratch& s = scratch_[thread];
    const size_t padded = size_t(g.lanes.padded);
    uint32_t positions[kBlock];
    const int n = sample_positions(node, positions);
    if (kernels_.row) {
      s.sample_features.resize(size_t(n) * padded);
      for (int i = 0; i < n; ++i)
        std::memcpy(s.sample_features.data() + i * padded, rows + positions[i] * padded, padded * sizeof(int16_t));
      set_lane_thresholds(g, s.sample_features.data(), n, thread);
      return;
    }
    int16_t column[kBlock];
    for (int c = 0; c < g.c1 - g.c0; ++c) {
      for (int i = 0; i < n; ++i) column[i] = rows[positions[i] * padded + g.lanes.lane[c]];
      set_thresholds(g.candidates[c], column, n);
    }
    finish_group(g);
  }
  // The same group when the sample's features come from all ranks: `features` holds
  // (c1 − c0) × sample_count values, candidate-major (sample_features()).
  void prepare_group_from(const NodeInfo& node, int c0, int c1, const int16_t* features, int sample_count,
                          CandidateGroup& g) const {
    g.c0 = c0;
    g.c1 = c1;
    g.candidates.resize(c1 - c0);
    for (int c = 0; c < c1 - c0; ++c) {
      draw_offsets(node, c0 + c, g.candidates[c]);
      set_thresholds(g.candidates[c], features + size_t(c) * sample_count, sample_count);
    }
    finish_group(g);
  }
  static void finish_group(CandidateGroup& g) {
    g.bins = 1;
    for (const Candidate& c : g.candidates) g.bins = std::max(g.bins, c.thresholds + 1);
    make_lanes(g.candidates, g.lanes);
  }
  // This rank's share of the features of candidates [c0, c1) at the node's threshold sample:
  // out[(c − c0) × sample_count + slot] for the slots this process holds, other entries left as
  // they are (zero), so that a sum over ranks yields every value exactly once.
  int sample_features(const NodeInfo& node, int c0, int c1, int16_t* out, int thread) {
    Scratch& s = scratch_[thread];
    uint32_t positions[kBlock];
    int slots[kBlock];
    const int count = sample_positions(node, positions);
    decode_owned(node, positions, count, s.sample, slots);
    for (int c = c0; c < c1; ++c) {
      Candidate cand{};
      draw_offsets(node, c, cand);
      block_features(s.sample, cand);
      for (int k = 0; k < s.sample.count; ++k) out[size_t(c - c0) * count + slots[k]] = s.sample.feature[k];
    }
    return count;
  }
  int sample_count(const NodeInfo& node) const {
    return static_cast<int>(std::min<uint32_t>(node.count, std::min(p_.threshold_candidates, kMaxThresholds)));
  }

  // Classification: adds pixels [begin, end) of `node` to `counts`, cells [class][bin][lane]
  // (histogram_cells of them): a pixel's increments for all candidates fall in its class's
  // bins × lanes block (a few kB, L1-resident). Integer counts: partial histograms over
  // disjoint pixel ranges sum to the same cells in any order (threads here; processes later).
  // `stored` (prepare_stored_group, pixels begin..end of the node): the pixels' features, binned
  // without evaluating them again.
  void accumulate(const NodeInfo& node, const CandidateGroup& g, uint32_t begin, uint32_t end, uint32_t* counts,
                  int thread, const int16_t* stored = nullptr) {
    const CandidateLanes& l = g.lanes;
    Scratch& s = scratch_[thread];
    s.feature.resize(l.padded);
    s.bin.resize(l.padded);
    s.cell.resize(l.padded);
    int16_t* bin = s.bin.data();
    for (uint32_t i = begin; i < end; ++i) {
      const TrainingPixel& p = px_[i];
      if (stored)
        bin_row(l, stored + size_t(i - node.begin) * l.padded, bin);
      else
        kernels_.pixel(l, images_[p.image], p.u, p.v, p.scale_q13, s.feature.data(), bin);
      count_pixel(g, bin, node.class_of[p.label], counts, s.cell.data());
    }
  }
  // Adds one pixel of compact class `cls` with bins `bin` (by lane) to a classification histogram
  // (cells [class][bin][lane]).
  // `cell`: scratch of g.lanes.padded entries.
  void count_pixel(const CandidateGroup& g, const int16_t* bin, int cls, uint32_t* counts, int32_t* cell) const {
    const int nc = g.c1 - g.c0;
    uint32_t* h = counts + size_t(cls) * g.bins * nc;
    if (kernels_.cells) {
      // The cells' indices with vector arithmetic first: the increments are then a load and an add.
      kernels_.cells(bin, nc, cell);
#pragma GCC unroll 4
      for (int c = 0; c < nc; ++c) ++h[cell[c]];
      return;
    }
    for (int c = 0; c < nc; ++c) ++h[bin[c] * nc + c];
  }
  // Adds one pixel's offsets (pixel_offsets) with bins `bin` (by lane) to a regression histogram
  // (accumulate_regression's cells).
  void add_regression_pixel(const CandidateGroup& g, const int16_t* bin, const int32_t* offsets, uint32_t* counts,
                            int64_t* sums) const {
    const size_t row = size_t(joints_) * 5;
    for (int c = 0; c < g.c1 - g.c0; ++c) {
      const size_t cell = size_t(c) * g.bins + bin[g.lanes.lane[c]];
      ++counts[cell];
      add_offsets(offsets, joints_, sums + cell * row);
    }
  }
  // Bins of one pixel's stored features (g.lanes.padded of them): the same bins as the pixel
  // kernels give.
  void bin_row(const CandidateLanes& l, const int16_t* feature, int16_t* bin) const {
    if (kernels_.bins)
      kernels_.bins(l, feature, bin);
    else
      bins_sse2(l, feature, bin);
  }

  // Classification: the best (candidate, threshold) of a group from its complete histogram.
  Best score_group(const NodeInfo& node, const CandidateGroup& g, const uint32_t* counts, ScoreScratch& scratch) const {
    const int k = node.classes, nc = g.c1 - g.c0, bins = g.bins;
    const uint32_t n = node.count;
    Best best;
    if (kernels_.row && n < uint32_t(kNLogNTable) && nc >= 4) {
      // Scores of all lanes first (four at a time, the last few lanes by the scalar rule), then
      // the same scan as below in candidate order: the same strict comparisons on the same values.
      scratch.scores.resize(size_t(nc) * bins);
      double* scores = scratch.scores.data();
      int lane = 0;
      for (; lane + 4 <= nc; lane += 4)
        score_lanes_avx2(counts, k, bins, nc, lane, bins - 1, node.totals.data(), n, scores);
      for (; lane < nc; ++lane) score_lane(node, counts + lane, nc, bins, bins - 1, scratch.cum, scores + size_t(lane) * bins);
      for (int c = 0; c < nc; ++c) {
        const Candidate& cand = g.candidates[c];
        const double* row = scores + size_t(g.lanes.lane[c]) * bins;
        for (int t = 0; t < cand.thresholds; ++t) best.consider(row[t], g.c0 + c, cand, t);
      }
      return best;
    }
    scratch.scores.resize(bins);
    for (int c = 0; c < nc; ++c) {
      const Candidate& cand = g.candidates[c];
      score_lane(node, counts + g.lanes.lane[c], nc, bins, cand.thresholds, scratch.cum, scratch.scores.data());
      for (int t = 0; t < cand.thresholds; ++t) best.consider(scratch.scores[t], g.c0 + c, cand, t);
    }
    return best;
  }
  // The scores of one lane (h = its first cell) at thresholds t < thresholds into out[t]; +∞ where
  // the threshold is skipped: nothing left of it, nothing right of it (then neither at any later
  // one), or an empty bin (which leaves every count, hence the score, as at the previous
  // threshold, which cannot win a strict comparison against itself).
  void score_lane(const NodeInfo& node, const uint32_t* h, int nc, int bins, int thresholds, std::vector<uint32_t>& cum,
                  double* out) const {
    const int k = node.classes;
    const uint32_t n = node.count;
    cum.assign(k, 0u);
    uint32_t left = 0;
    for (int t = 0; t < thresholds; ++t) {
      out[t] = HUGE_VAL;
      uint32_t in_bin = 0;
      for (int j = 0; j < k; ++j) {
        const uint32_t cell = h[(size_t(j) * bins + t) * nc];
        cum[j] += cell;
        in_bin += cell;
      }
      left += in_bin;
      if (left == 0 || left == n || in_bin == 0) continue;
      const uint32_t right = n - left;
      double wl = nlogn(left), wr = nlogn(right);
      for (int j = 0; j < k; ++j) {
        wl -= nlogn(cum[j]);
        wr -= nlogn(node.totals[j] - cum[j]);
      }
      out[t] = (wl + wr) / n;
    }
  }

  // Regression histogram of a group: counts[c × bins + bin] pixels and sums[(c × bins + bin) ×
  // joints × 5] fixed-point offset sums (add_offsets) of pixels [begin, end) of `node`.
  size_t regression_sums(const CandidateGroup& g) const { return size_t(g.c1 - g.c0) * g.bins * joints_ * 5; }
  void accumulate_regression(const CandidateGroup& g, uint32_t begin, uint32_t end, uint32_t* counts,
                             int64_t* sums, int thread, const int16_t* stored = nullptr) {
    Scratch& s = scratch_[thread];
    const CandidateLanes& l = g.lanes;
    s.feature.resize(l.padded);
    s.bin.resize(l.padded);
    s.offsets.resize(size_t(joints_) * 4);
    for (uint32_t i = begin; i < end; ++i) {
      const TrainingPixel& p = px_[i];
      if (stored)
        bin_row(l, stored + size_t(i - begin) * l.padded, s.bin.data());
      else
        kernels_.pixel(l, images_[p.image], p.u, p.v, p.scale_q13, s.feature.data(), s.bin.data());
      pixel_offsets(p, s.offsets.data());
      add_regression_pixel(g, s.bin.data(), s.offsets.data(), counts, sums);
    }
  }

  // Regression: the best (candidate, threshold) of a group from its complete histogram.
  Best score_regression(const NodeInfo& node, const CandidateGroup& g, const uint32_t* counts, const int64_t* sums,
                        int thread) {
    Scratch& s = scratch_[thread];
    const int nc = g.c1 - g.c0, bins = g.bins, J = joints_;
    const size_t row = size_t(J) * 5;
    const uint32_t n = node.count;
    std::vector<int64_t> total(row), left(row);
    s.left.resize(J);
    s.right.resize(J);
    Best best;
    for (int c = 0; c < nc; ++c) {
      const Candidate& cand = g.candidates[c];
      const int64_t* h = sums + size_t(c) * bins * row;
      std::fill(total.begin(), total.end(), int64_t(0));
      for (int t = 0; t <= cand.thresholds; ++t)
        for (size_t k = 0; k < row; ++k) total[k] += h[t * row + k];
      std::fill(left.begin(), left.end(), int64_t(0));
      const uint32_t* pixel_bins = counts + size_t(c) * bins;
      uint32_t left_pixels = 0;
      for (int t = 0; t < cand.thresholds; ++t) {
        for (size_t k = 0; k < row; ++k) left[k] += h[t * row + k];
        left_pixels += pixel_bins[t];
        if (left_pixels == 0) continue;
        const uint32_t right_pixels = n - left_pixels;
        if (right_pixels == 0) break;
        for (int j = 0; j < J; ++j) {
          int64_t r[5];
          for (int k = 0; k < 5; ++k) r[k] = total[5 * j + k] - left[5 * j + k];
          s.left[j] = stats_of(&left[5 * j]);
          s.right[j] = stats_of(r);
        }
        best.consider(regression_objective(s.left.data(), s.right.data(), J, left_pixels, right_pixels), g.c0 + c,
                      cand, t);
      }
    }
    return best;
  }

  // Evaluates candidates [c0, c1) of `node` over all its pixels; returns the best.
  Best evaluate(const NodeInfo& node, int c0, int c1, int thread) {
    CandidateGroup& g = groups_[thread];
    const int16_t* stored = nullptr;
    if (stores_features(node, c0, c1))
      stored = prepare_stored_group(node, c0, c1, g, thread);
    else
      prepare_group(node, c0, c1, g, thread);
    return search_group(node, g, stored, thread);
  }
  // The histogram of a prepared group over all the node's pixels (features from `stored` when
  // given, else evaluated) and its best split.
  Best search_group(const NodeInfo& node, CandidateGroup& g, const int16_t* stored, int thread) {
    Scratch& s = scratch_[thread];
    const int c0 = g.c0, c1 = g.c1;
    if (p_.objective == Objective::kClassification) {
      s.counts.assign(g.histogram_cells(node), 0);
      accumulate(node, g, node.begin, node.end, s.counts.data(), thread, stored);
      return score_group(node, g, s.counts.data(), s.score);
    }
    s.counts.assign(size_t(c1 - c0) * g.bins, 0);
    s.sums.assign(regression_sums(g), 0);
    accumulate_regression(g, node.begin, node.end, s.counts.data(), s.sums.data(), thread, stored);
    return score_regression(node, g, s.counts.data(), s.sums.data(), thread);
  }

  // Node-parallel deep levels (search_node_parallel). What a rank sends a node's owner per pixel:
  // its target (classification: the label byte and a zero byte, so that every part keeps the
  // int16 features 2-byte aligned; regression: pixel_offsets, joints × 4 int32) and, per work item,
  // the features of its candidates (int16, in lane order).
  size_t target_bytes() const { return classification() ? 2 : size_t(joints_) * 4 * sizeof(int32_t); }
  void local_targets(const NodeInfo& node, uint8_t* out) const {
    std::vector<int32_t> o(4 * size_t(joints_));
    for (uint32_t i = node.begin; i < node.end; ++i, out += target_bytes()) {
      if (classification()) {
        out[0] = px_[i].label;
        out[1] = 0;
      } else {
        pixel_offsets(px_[i], o.data());
        std::memcpy(out, o.data(), target_bytes());
      }
    }
  }
  // Features of candidates [c0, c1) of `node` at this process's pixels of it: (c1 − c0) per pixel
  // in lane order (make_offset_lanes), pixels in order.
  void local_features(const NodeInfo& node, int c0, int c1, int16_t* out, int thread) {
    Scratch& s = scratch_[thread];
    CandidateGroup& g = groups_[thread];
    draw_group(node, c0, c1, g);
    const size_t padded = size_t(g.lanes.padded), nc = size_t(c1 - c0), n = node.end - node.begin;
    s.node_features.resize(n * padded);
    feature_rows(g, node.begin, node.end, s.node_features.data());
    for (size_t i = 0; i < n; ++i) std::memcpy(out + i * nc, s.node_features.data() + i * padded, nc * sizeof(int16_t));
  }
  // What evaluate() finds for candidates [c0, c1) of `node`, from all its pixels' features
  // (`features`: node.count × (c1 − c0), as local_features gives them, ranks' pixels in rank
  // order = the node's global order) and targets (local_targets likewise): the same threshold
  // sample, thresholds, histograms and scoring as one process, hence the same split.
  Best evaluate_gathered(const NodeInfo& node, int c0, int c1, const int16_t* features, const uint8_t* targets,
                         int thread) {
    Scratch& s = scratch_[thread];
    CandidateGroup& g = groups_[thread];
    draw_group(node, c0, c1, g);
    const size_t padded = size_t(g.lanes.padded), nc = size_t(c1 - c0), n = node.count;
    s.node_features.assign(n * padded, 0);
    int16_t* rows = s.node_features.data();
    for (size_t i = 0; i < n; ++i) std::memcpy(rows + i * padded, features + i * nc, nc * sizeof(int16_t));
    thresholds_from_rows(node, rows, g, thread);
    s.bin.resize(padded);
    s.cell.resize(padded);
    if (classification()) {
      s.counts.assign(g.histogram_cells(node), 0);
      for (size_t i = 0; i < n; ++i) {
        bin_row(g.lanes, rows + i * padded, s.bin.data());
        count_pixel(g, s.bin.data(), node.class_of[targets[i * target_bytes()]], s.counts.data(), s.cell.data());
      }
      return score_group(node, g, s.counts.data(), s.score);
    }
    s.counts.assign(nc * g.bins, 0);
    s.sums.assign(regression_sums(g), 0);
    s.offsets.resize(size_t(joints_) * 4);
    for (size_t i = 0; i < n; ++i) {
      bin_row(g.lanes, rows + i * padded, s.bin.data());
      std::memcpy(s.offsets.data(), targets + i * target_bytes(), target_bytes());
      add_regression_pixel(g, s.bin.data(), s.offsets.data(), s.counts.data(), s.sums.data());
    }
    return score_regression(node, g, s.counts.data(), s.sums.data(), thread);
  }

  // Candidates per candidate group (work item) of `node` on a level with `splittable` nodes to
  // search. More candidates per group means each pixel's neighbourhood, once in cache, serves more
  // probes. Classification groups hold as many as keep the group's histogram within
  // kItemHistogramEntries, or kRangeHistogramEntries near the root (fewer than 8
  // nodes per thread), where groups are shared among threads by pixel ranges instead (grow_tree).
  // The chosen split does not depend on it (ties go to the lowest candidate across groups).
  int chunk_for(const NodeInfo& node, size_t splittable) const {
    if (p_.objective != Objective::kClassification) return chunk_;
    const size_t cap = splittable < size_t(8 * std::max(1, p_.threads)) ? kRangeHistogramEntries : kItemHistogramEntries;
    const size_t bins = size_t(std::min<uint32_t>(node.count, p_.threshold_candidates)) + 1;
    const size_t fit = cap / (bins * std::max(1, node.classes));
    return static_cast<int>(std::max<size_t>(chunk_, fit / kLanes * kLanes));
  }

  size_t scratch_bytes() const {
    size_t b = 0;
    for (const Scratch& s : scratch_)
      b += sizeof(Scratch) + s.candidates.capacity() * sizeof(Candidate) + s.counts.capacity() * 4 +
           s.sums.capacity() * 8 + s.offsets.capacity() * 4 + s.node_features.capacity() * 2;
    return b;
  }

 private:
  const TrainingSet& set_;
  std::vector<TrainingPixel>& px_;
  int tree_;
  TreeParams p_;
  int joints_ = 0;
  int chunk_ = 16;
  std::vector<ImageRef> images_;
  std::vector<std::vector<uint16_t>> padded_probes_;  // copies of unpadded images (see the constructor)
  TrainKernels kernels_;
  std::vector<Scratch> scratch_;
  std::vector<CandidateGroup> groups_;  // per thread, for evaluate()
};

// A work item of a level's split search: candidates [c0, c1) of frontier node `node`.
struct Item {
  uint32_t node;
  int c0, c1;
};

// Distributed levels (params.comm): the frontier's statistics over all ranks. Each rank counts its
// own pixels per node (labels or fixed-point offset sums); one sum gives every rank the node's
// global count, its statistics and where each rank's pixels start in the node's global order
// (ranks hold contiguous image ranges and partitions are stable, so that order is rank order).
// Returns every rank's pixel count of every node (node f, rank r at f × ranks + r).
std::vector<uint32_t> gather_node_stats(Grower& grower, std::vector<NodeInfo>& info, Communicator& comm, int threads) {
  const size_t ranks = size_t(comm.size()), labels = 256, sums = size_t(grower.stats_sums());
  const size_t stride = ranks + labels;
  std::vector<uint32_t> counts(info.size() * stride, 0);
  std::vector<int64_t> offsets(info.size() * sums, 0);
  parallel_for(info.size(), threads, [&](size_t f, int) {
    uint32_t* c = counts.data() + f * stride;
    c[comm.rank()] = info[f].end - info[f].begin;
    grower.local_stats(info[f], c + ranks, offsets.data() + f * sums);
  });
  comm.sum(counts.data(), counts.size());
  if (sums) comm.sum(offsets.data(), offsets.size());
  parallel_for(info.size(), threads, [&](size_t f, int) {
    const uint32_t* c = counts.data() + f * stride;
    uint32_t total = 0;
    for (size_t r = 0; r < ranks; ++r) {
      if (r == size_t(comm.rank())) info[f].first = total;
      total += c[r];
    }
    grower.finish(info[f], total, c + ranks, offsets.data() + f * sums);
  });
  std::vector<uint32_t> rank_counts(info.size() * ranks);
  for (size_t f = 0; f < info.size(); ++f)
    std::copy(counts.begin() + f * stride, counts.begin() + f * stride + ranks, rank_counts.begin() + f * ranks);
  return rank_counts;
}

// Gives every rank results[0, n): item i's record comes from the one rank where mine(i) holds
// (the others' entries are ignored), in one sum where each record has one non-zero term.
void share_results(Best* results, size_t n, const std::function<bool(size_t)>& mine, Communicator& comm) {
  constexpr size_t kFields = 7;  // score bits, candidate, du1, dv1, du2, dv2, threshold
  std::vector<int64_t> shared(n * kFields, 0);
  for (size_t i = 0; i < n; ++i) {
    if (!mine(i)) continue;
    const Best& b = results[i];
    int64_t* f = &shared[i * kFields];
    std::memcpy(&f[0], &b.score, sizeof b.score);
    f[1] = b.candidate;
    f[2] = b.du1;
    f[3] = b.dv1;
    f[4] = b.du2;
    f[5] = b.dv2;
    f[6] = b.threshold;
  }
  comm.sum(shared.data(), shared.size());
  for (size_t i = 0; i < n; ++i) {
    const int64_t* f = &shared[i * kFields];
    Best& b = results[i];
    std::memcpy(&b.score, &f[0], sizeof b.score);
    b.candidate = static_cast<int>(f[1]);
    b.du1 = static_cast<int32_t>(f[2]);
    b.dv1 = static_cast<int32_t>(f[3]);
    b.du2 = static_cast<int32_t>(f[4]);
    b.dv2 = static_cast<int32_t>(f[5]);
    b.threshold = static_cast<int32_t>(f[6]);
  }
}

// Upper bound on the histogram bytes of one batch of a distributed level (all its work items'
// histograms are summed over ranks at once). 16 MiB: messages large enough that MPI's per-call
// latency (~10 µs here, ~2 µs on InfiniBand) is negligible next to moving them, while the
// batch's buffers (histograms + MPI's reduction scratch, ~3× this) stay small next to a rank's
// images; measured with 64 MiB the ranks' peak resident memory was 257 MB for 2.5 MB of images.
constexpr size_t kBatchHistogramBytes = size_t(16) << 20;

// Distributed split search of one level: work items in batches whose histograms fit
// kBatchHistogramBytes. Per batch, (1) each rank computes the features of the candidates at the
// threshold-sample pixels it holds and one sum gives every rank every node's thresholds; (2) each
// rank accumulates the items' histograms over its own pixels; (3) one sum (integers: exact)
// gives the complete histograms; (4) every rank scores them identically. The batches depend only
// on global values, so every rank makes the same collective calls.
void search_distributed(Grower& grower, const std::vector<NodeInfo>& info, const std::vector<Item>& items,
                        std::vector<Best>& results, Communicator& comm, int threads) {
  const bool classification = grower.classification();
  const size_t joints5 = size_t(grower.stats_sums() ? grower.stats_sums() : 0);
  for (size_t b0 = 0; b0 < items.size();) {
    // Batch bounds from an upper bound of each item's histogram (bins ≤ sample + 1).
    size_t b1 = b0, bytes = 0;
    while (b1 < items.size()) {
      const NodeInfo& node = info[items[b1].node];
      const size_t cells = size_t(items[b1].c1 - items[b1].c0) * (grower.sample_count(node) + 1);
      const size_t item_bytes = classification ? cells * node.classes * 4 : cells * (4 + joints5 * 8);
      if (b1 > b0 && bytes + item_bytes > kBatchHistogramBytes) break;
      bytes += item_bytes;
      ++b1;
    }
    const size_t n = b1 - b0;
    // (1) threshold samples
    std::vector<size_t> feature_at(n + 1, 0);
    for (size_t i = 0; i < n; ++i) {
      const Item& it = items[b0 + i];
      feature_at[i + 1] = feature_at[i] + size_t(it.c1 - it.c0) * grower.sample_count(info[it.node]);
    }
    std::vector<int16_t> features(feature_at[n], 0);
    parallel_for(n, threads, [&](size_t i, int thread) {
      const Item& it = items[b0 + i];
      grower.sample_features(info[it.node], it.c0, it.c1, features.data() + feature_at[i], thread);
    });
    {
      // int16 values travel as int32 (each sum has one non-zero term, so the result is exact).
      std::vector<uint32_t> wide(features.size());
      for (size_t k = 0; k < features.size(); ++k) wide[k] = static_cast<uint32_t>(int32_t(features[k]));
      comm.sum(wide.data(), wide.size());
      for (size_t k = 0; k < features.size(); ++k) features[k] = static_cast<int16_t>(int32_t(wide[k]));
    }
    std::vector<Grower::CandidateGroup> groups(n);
    parallel_for(n, threads, [&](size_t i, int) {
      const Item& it = items[b0 + i];
      const NodeInfo& node = info[it.node];
      grower.prepare_group_from(node, it.c0, it.c1, features.data() + feature_at[i], grower.sample_count(node),
                                groups[i]);
    });
    // (2) local histograms
    std::vector<size_t> count_at(n + 1, 0), sum_at(n + 1, 0);
    for (size_t i = 0; i < n; ++i) {
      const NodeInfo& node = info[items[b0 + i].node];
      const size_t cells = classification ? groups[i].histogram_cells(node)
                                          : size_t(groups[i].c1 - groups[i].c0) * groups[i].bins;
      count_at[i + 1] = count_at[i] + cells;
      sum_at[i + 1] = sum_at[i] + (classification ? 0 : grower.regression_sums(groups[i]));
    }
    std::vector<uint32_t> counts(count_at[n], 0);
    std::vector<int64_t> sums(sum_at[n], 0);
    parallel_for(n, threads, [&](size_t i, int thread) {
      const NodeInfo& node = info[items[b0 + i].node];
      if (classification)
        grower.accumulate(node, groups[i], node.begin, node.end, counts.data() + count_at[i], thread);
      else
        grower.accumulate_regression(groups[i], node.begin, node.end, counts.data() + count_at[i],
                                     sums.data() + sum_at[i], thread);
    });
    // (3) complete histograms, (4) scores: item i is scored by rank i mod N only (scoring costs as
    // much as accumulating once nodes hold ~100 pixels), and one more sum shares the results.
    comm.sum(counts.data(), counts.size());
    if (!classification) comm.sum(sums.data(), sums.size());
    const size_t ranks = size_t(comm.size()), me = size_t(comm.rank());
    parallel_for(n, threads, [&](size_t i, int thread) {
      if (i % ranks != me) return;
      const NodeInfo& node = info[items[b0 + i].node];
      if (classification) {
        ScoreScratch scratch;
        results[b0 + i] = grower.score_group(node, groups[i], counts.data() + count_at[i], scratch);
      } else {
        results[b0 + i] = grower.score_regression(node, groups[i], counts.data() + count_at[i],
                                                  sums.data() + sum_at[i], thread);
      }
    });
    share_results(results.data() + b0, n, [&](size_t i) { return i % ranks == me; }, comm);
    b0 = b1;
  }
}

// Upper bound on the features one batch of a deep level holds (int16, pixels × lanes): 1 GiB,
// 1.3 M pixels at 400 candidates (TreeParams::level_feature_bytes overrides it). See
// search_image_major.
constexpr size_t kLevelFeatureBytes = size_t(1) << 30;

// One process's split search over a level's work items when every item is a whole node (all
// candidates, no pixel ranges) and the AVX2 kernel runs: deep in a tree. A deep node's pixels come
// from as many images, so the node-major walk loads a new image's probe neighbourhood (hundreds of
// cache lines, from memory: a corpus's images are gigabytes) for every pixel. Here consecutive
// nodes form batches whose features fit kLevelFeatureBytes; a batch's pixels are walked in image
// order (a counting sort by image), each with its own node's candidate lanes, so an image is
// loaded once for all of its pixels in the batch, and the features land in each node's rows. Then
// every node's thresholds, histogram and best split come from its rows exactly as for a small
// node's stored features (evaluate_rows): the same values, hence the same splits.
// `finished(n)` reports n items done.
void search_image_major(Grower& grower, const std::vector<NodeInfo>& info, const std::vector<Item>& items,
                        std::vector<Best>& results, int padded, int threads, size_t batch_bytes,
                        std::vector<int16_t>& rows, const std::function<void(size_t)>& finished) {
  const size_t max_rows = std::max<size_t>(1, batch_bytes / (size_t(padded) * sizeof(int16_t)));
  auto pixels = [&](size_t item) -> size_t { return info[items[item].node].end - info[items[item].node].begin; };
  // A node larger than a batch keeps the node-major walk (its pixels come ≥ 1 per image there:
  // the walk is cache-friendly) and its own work item, all such nodes side by side on the threads.
  std::vector<size_t> large, small;
  for (size_t i = 0; i < items.size(); ++i) (pixels(i) > max_rows ? large : small).push_back(i);
  parallel_for(large.size(), threads, [&](size_t k, int thread) {
    const Item& it = items[large[k]];
    results[large[k]] = grower.evaluate(info[it.node], it.c0, it.c1, thread);
  });
  size_t done = large.size();
  if (!large.empty()) finished(done);
  if (small.empty()) return;
  // The buffer holds the largest batch of this level, allocated once at its exact size.
  size_t largest = 0;
  for (size_t b0 = 0; b0 < small.size();) {
    size_t total = 0;
    for (; b0 < small.size() && total + pixels(small[b0]) <= max_rows; ++b0) total += pixels(small[b0]);
    largest = std::max(largest, total);
  }
  if (rows.size() < largest * padded) {
    std::vector<int16_t>().swap(rows);
    rows.resize(largest * padded);
  }
  struct Entry {
    uint32_t pixel, item;  // item: index within the batch
  };
  std::vector<CandidateLanes> lanes;
  std::vector<size_t> first_row;
  std::vector<uint32_t> slot(grower.image_count() + 1);
  std::vector<Entry> order;
  for (size_t b0 = 0; b0 < small.size();) {
    size_t b1 = b0, total = 0;
    for (; b1 < small.size() && total + pixels(small[b1]) <= max_rows; ++b1) total += pixels(small[b1]);
    const size_t m = b1 - b0;
    auto node_of = [&](size_t k) -> const NodeInfo& { return info[items[small[b0 + k]].node]; };
    if (lanes.size() < m) lanes.resize(m);
    first_row.assign(m + 1, 0);
    for (size_t k = 0; k < m; ++k) first_row[k + 1] = first_row[k] + pixels(small[b0 + k]);
    parallel_for(m, threads, [&](size_t k, int thread) { grower.offset_lanes(node_of(k), lanes[k], thread); });
    // Counting sort of the batch's pixels by image (stable: within an image, in item then pixel order).
    std::fill(slot.begin(), slot.end(), 0u);
    for (size_t k = 0; k < m; ++k)
      for (uint32_t i = node_of(k).begin; i < node_of(k).end; ++i) ++slot[grower.image_of(i) + 1];
    for (size_t j = 1; j < slot.size(); ++j) slot[j] += slot[j - 1];
    order.resize(total);
    for (size_t k = 0; k < m; ++k)
      for (uint32_t i = node_of(k).begin; i < node_of(k).end; ++i) order[slot[grower.image_of(i)]++] = {i, uint32_t(k)};
    const size_t chunks = std::min(total, size_t(64) * std::max(1, threads));
    parallel_for(chunks, threads, [&](size_t c, int) {
      for (size_t e = total * c / chunks; e < total * (c + 1) / chunks; ++e) {
        const Entry& x = order[e];
        const size_t row = first_row[x.item] + (x.pixel - node_of(x.item).begin);
        grower.pixel_feature_row(lanes[x.item], x.pixel, rows.data() + row * padded);
      }
    });
    parallel_for(m, threads, [&](size_t k, int thread) {
      results[small[b0 + k]] = grower.evaluate_rows(node_of(k), rows.data() + first_row[k] * padded, thread);
    });
    done += m;
    b0 = b1;
    finished(done);
  }
}

// Node-parallel split search (docs/training.md "What is communicated per level") of the work items of
// nodes with few pixels, `items` grouped by node in frontier order. Each node is owned by one rank
// (the least loaded so far in frontier order, counting its pixels, ties to the lowest rank: the
// same on every rank). In batches of nodes whose data fit kBatchHistogramBytes, (1) every rank
// computes, for its own pixels of each node, their targets and every candidate's features and
// sends them to the node's owner (one exchange); (2) the owner lays the ranks' parts end to end in
// rank order — the node's global pixel order — and runs evaluate()'s search on them
// (evaluate_gathered); (3) one sum shares the owners' results. Nothing per node is repeated on
// other ranks beyond drawing the candidates their pixels are evaluated on; the batches depend
// only on global counts, so every rank makes the same collective calls.
void search_node_parallel(Grower& grower, const std::vector<NodeInfo>& info, const std::vector<uint32_t>& rank_counts,
                          const std::vector<Item>& items, std::vector<Best>& results, Communicator& comm,
                          int threads) {
  const size_t ranks = size_t(comm.size()), me = size_t(comm.rank());
  struct OwnedNode {
    uint32_t node;
    size_t i0, i1;  // its items
    size_t owner;
    size_t pixel_bytes;  // per pixel: target + features of every item
  };
  std::vector<OwnedNode> nodes;
  std::vector<uint64_t> load(ranks, 0);
  for (size_t i = 0; i < items.size();) {
    OwnedNode o{items[i].node, i, i, 0, grower.target_bytes()};
    for (; o.i1 < items.size() && items[o.i1].node == o.node; ++o.i1)
      o.pixel_bytes += size_t(items[o.i1].c1 - items[o.i1].c0) * sizeof(int16_t);
    o.owner = size_t(std::min_element(load.begin(), load.end()) - load.begin());
    load[o.owner] += info[o.node].count;
    nodes.push_back(o);
    i = o.i1;
  }
  // The bytes rank r sends for node k of `nodes`, and where item i's features start in them.
  auto part_bytes = [&](const OwnedNode& o, size_t r) { return size_t(rank_counts[o.node * ranks + r]) * o.pixel_bytes; };
  auto item_offset = [&](const OwnedNode& o, size_t i, size_t pixels) {
    return pixels * (grower.target_bytes() + size_t(items[i].c0 - items[o.i0].c0) * sizeof(int16_t));
  };
  for (size_t k0 = 0; k0 < nodes.size();) {
    size_t k1 = k0, bytes = 0;
    while (k1 < nodes.size()) {
      const size_t node_bytes = size_t(info[nodes[k1].node].count) * nodes[k1].pixel_bytes;
      if (k1 > k0 && bytes + node_bytes > kBatchHistogramBytes) break;
      bytes += node_bytes;
      ++k1;
    }
    // (1) this rank's parts, to each owner in batch order
    std::vector<std::vector<uint8_t>> parts(ranks);
    std::vector<size_t> at(k1 - k0);
    {
      std::vector<size_t> size(ranks, 0);
      for (size_t k = k0; k < k1; ++k) {
        at[k - k0] = size[nodes[k].owner];
        size[nodes[k].owner] += part_bytes(nodes[k], me);
      }
      for (size_t r = 0; r < ranks; ++r) parts[r].resize(size[r]);
    }
    parallel_for(k1 - k0, threads, [&](size_t k, int thread) {
      const OwnedNode& o = nodes[k0 + k];
      const NodeInfo& node = info[o.node];
      const size_t pixels = node.end - node.begin;
      if (pixels == 0) return;
      uint8_t* out = parts[o.owner].data() + at[k];
      grower.local_targets(node, out);
      for (size_t i = o.i0; i < o.i1; ++i)
        grower.local_features(node, items[i].c0, items[i].c1,
                              reinterpret_cast<int16_t*>(out + item_offset(o, i, pixels)), thread);
    });
    const std::vector<std::vector<uint8_t>> received = comm.exchange(parts);
    std::vector<std::vector<uint8_t>>().swap(parts);
    // (2) the owned nodes, assembled in global pixel order, then searched
    std::vector<size_t> owned;
    for (size_t k = k0; k < k1; ++k)
      if (nodes[k].owner == me) owned.push_back(k);
    std::vector<std::vector<uint8_t>> gathered(owned.size());
    std::vector<size_t> cursor(ranks, 0);
    for (size_t j = 0; j < owned.size(); ++j) {
      const OwnedNode& o = nodes[owned[j]];
      const size_t n = info[o.node].count;
      gathered[j].resize(n * o.pixel_bytes);
      size_t first = 0;  // the sender's first pixel in the node's global order
      for (size_t r = 0; r < ranks; ++r) {
        const size_t m = rank_counts[o.node * ranks + r];
        const uint8_t* in = received[r].data() + cursor[r];
        std::memcpy(gathered[j].data() + first * grower.target_bytes(), in, m * grower.target_bytes());
        for (size_t i = o.i0; i < o.i1; ++i) {
          const size_t row = size_t(items[i].c1 - items[i].c0) * sizeof(int16_t);
          std::memcpy(gathered[j].data() + item_offset(o, i, n) + first * row, in + item_offset(o, i, m), m * row);
        }
        cursor[r] += m * o.pixel_bytes;
        first += m;
      }
    }
    std::vector<std::pair<size_t, size_t>> work;  // (owned node j, item i)
    for (size_t j = 0; j < owned.size(); ++j)
      for (size_t i = nodes[owned[j]].i0; i < nodes[owned[j]].i1; ++i) work.push_back({j, i});
    parallel_for(work.size(), threads, [&](size_t w, int thread) {
      const auto [j, i] = work[w];
      const OwnedNode& o = nodes[owned[j]];
      const NodeInfo& node = info[o.node];
      const uint8_t* data = gathered[j].data();
      results[i] = grower.evaluate_gathered(node, items[i].c0, items[i].c1,
                                            reinterpret_cast<const int16_t*>(data + item_offset(o, i, node.count)),
                                            data, thread);
    });
    // (3) the owners' results to every rank
    const size_t i0 = nodes[k0].i0, i1 = nodes[k1 - 1].i1;
    std::vector<size_t> owner_of(i1 - i0);
    for (size_t k = k0; k < k1; ++k)
      for (size_t i = nodes[k].i0; i < nodes[k].i1; ++i) owner_of[i - i0] = nodes[k].owner;
    share_results(results.data() + i0, i1 - i0, [&](size_t i) { return owner_of[i] == me; }, comm);
    k0 = k1;
  }
}

struct GrowNode {
  uint32_t heap;
  uint32_t begin, end;
  bool leaf = true;
  int32_t du1 = 0, dv1 = 0, du2 = 0, dv2 = 0, threshold = 0;
};

}  // namespace

void sort_int16_columns(int16_t* rows, int n, size_t stride, int lanes, std::vector<uint16_t>& network) {
  if (n < 2) return;
  batcher_network(n, network);
  if (__builtin_cpu_supports("avx2")) {
    sort_columns_avx2(rows, stride, (lanes + 15) / 16 * 16, network);
    return;
  }
  for (size_t k = 1; k + 1 < network.size(); k += 2)
    for (int c = 0; c < lanes; ++c) {
      int16_t& x = rows[network[k] * stride + c];
      int16_t& y = rows[network[k + 1] * stride + c];
      const int16_t low = std::min(x, y), high = std::max(x, y);
      x = low;
      y = high;
    }
}

GrownTree grow_tree(const TrainingSet& set, std::vector<TrainingPixel> pixels, int tree_index,
                    const TreeParams& params, const ProgressFn& progress, const GrowthState* resume,
                    const LevelDoneFn& level_done) {
  const auto tree_start = std::chrono::steady_clock::now();
  Communicator* comm = params.comm;
  {
    uint32_t total = static_cast<uint32_t>(std::min<size_t>(pixels.size(), UINT32_MAX / 4));
    if (comm) comm->sum(&total, 1);
    if (total == 0) fail("tree " + std::to_string(tree_index) + ": no training pixels");
  }
  if (params.max_depth < 1 || params.max_depth > kMaxForestDepth)
    fail("--depth must be 1.." + std::to_string(kMaxForestDepth));
  if (params.offset_candidates < 1) fail("--offsets must be ≥ 1");
  if (params.threshold_candidates < 1 || params.threshold_candidates > kMaxThresholds)
    fail("--thresholds must be 1.." + std::to_string(kMaxThresholds));
  if (params.max_offset_pxm < 0 || params.max_offset_pxm > 4096) fail("--max-offset must be 0..4096 pixel·metres");
  if (params.objective == Objective::kRegression && !(params.rho_m > 0 && params.rho_m <= kMaxRhoM))
    fail("--rho must be in (0, " + std::to_string(int(kMaxRhoM)) + "] metres");
  if (params.objective == Objective::kClassification && !set.has_labels)
    fail("the classification objective needs part labels (datasets with parts/)");
  if (params.objective == Objective::kRegression && (!set.has_joints || set.joint_names.empty()))
    fail("the regression objective needs joints in every frame");
  if (pixels.size() > UINT32_MAX / 2) fail("too many training pixels for one tree");
  if (params.node_parallel_pixels > kMaxNodeParallelPixels)
    fail("--node-parallel-below must be 0.." + std::to_string(kMaxNodeParallelPixels) + " pixels");

  GrownTree out;
  Grower grower(set, pixels, tree_index, params);
  std::vector<TrainingPixel> tmp(pixels.size());
  std::vector<GrowNode> nodes;
  nodes.push_back({0, 0, static_cast<uint32_t>(pixels.size())});
  std::vector<size_t> frontier = {0};
  const int threads = std::max(1, params.threads);
  const int replay_levels = resume ? resume->levels_done : 0;
  size_t range_peak_bytes = 0;  // candidate groups and partial histograms of the range levels
  std::vector<int16_t> level_rows;  // deep levels' features (search_image_major)
  size_t replay_next = 0;  // next decision of resume->nodes (heap order = breadth-first order)
  if (resume) out.feature_evaluations = resume->feature_evaluations;
  for (int level = 0; !frontier.empty(); ++level) {
    const auto level_start = std::chrono::steady_clock::now();
    if (level < replay_levels) {
      // Replay: the frontier is in heap order (children are appended in their parents' order),
      // and so are the recorded decisions of this level.
      for (size_t f = 0; f < frontier.size(); ++f) {
        GrowNode& g = nodes[frontier[f]];
        if (replay_next >= resume->nodes.size() || resume->nodes[replay_next].heap != g.heap)
          fail("checkpoint: tree " + std::to_string(tree_index) + " has no decision for node " +
               std::to_string(g.heap) + " at level " + std::to_string(level) +
               " (the checkpoint belongs to other data or options)");
        const DecidedNode& d = resume->nodes[replay_next++];
        g.leaf = d.leaf;
        g.du1 = d.du1;
        g.dv1 = d.dv1;
        g.du2 = d.du2;
        g.dv2 = d.dv2;
        g.threshold = d.threshold;
      }
    }
    std::vector<NodeInfo> info(level < replay_levels ? 0 : frontier.size());
    for (size_t f = 0; f < info.size(); ++f) {
      const GrowNode& g = nodes[frontier[f]];
      info[f].heap = g.heap;
      info[f].begin = g.begin;
      info[f].end = g.end;
      info[f].level = level;
    }
    const uint64_t reduced_before = comm ? comm->bytes_reduced() : 0;
    const uint64_t exchanged_before = comm ? comm->bytes_exchanged() : 0;
    std::vector<uint32_t> rank_counts;
    if (comm)
      rank_counts = gather_node_stats(grower, info, *comm, threads);
    else
      parallel_for(info.size(), threads, [&](size_t f, int) { grower.prepare(info[f]); });

    std::vector<Item> items;
    std::vector<size_t> first_item(info.size() + 1, 0);
    size_t splittable = 0;
    for (const NodeInfo& n : info) splittable += n.splittable;
    uint64_t evaluations = 0;
    size_t active = 0;
    for (size_t f = 0; f < info.size(); ++f) {
      first_item[f] = items.size();
      if (!info[f].splittable) continue;
      active += info[f].count;
      evaluations += uint64_t(info[f].count) * params.offset_candidates;
      const int chunk = grower.chunk_for(info[f], splittable);
      for (int c = 0; c < params.offset_candidates; c += chunk)
        items.push_back({static_cast<uint32_t>(f), c, std::min(params.offset_candidates, c + chunk)});
    }
    first_item[info.size()] = items.size();
    std::vector<Best> results(items.size());
    std::atomic<size_t> items_done{0};
    auto last_beat = std::chrono::steady_clock::now();
    // Near the root (few nodes, many pixels each) a node's pixels are dealt out in ranges: each
    // work item accumulates the histograms of a whole candidate group over one range, so every
    // pixel's neighbourhood is loaded once for all the group's candidates, and the integer partial
    // histograms are summed per group before scoring. Deeper, items are (node, candidate chunk)
    // over all the node's pixels. Both give the same counts, hence the same splits.
    const bool by_ranges = !comm && params.objective == Objective::kClassification && splittable > 0 &&
                           splittable < size_t(8 * threads) && level >= replay_levels;
    std::vector<Grower::CandidateGroup> groups(by_ranges ? items.size() : 0);
    struct RangeItem {
      uint32_t group, begin, end;
    };
    std::vector<RangeItem> ranges;
    std::vector<std::vector<uint32_t>> partial;
    if (by_ranges) {
      parallel_for(items.size(), threads, [&](size_t i, int thread) {
        grower.prepare_group(info[items[i].node], items[i].c0, items[i].c1, groups[i], thread);
      });
      const size_t wanted = size_t(16 * threads);
      for (size_t i = 0; i < items.size(); ++i) {
        const NodeInfo& node = info[items[i].node];
        const uint32_t n = node.end - node.begin;
        const uint32_t pieces = static_cast<uint32_t>(std::clamp<size_t>(
            (wanted + items.size() - 1) / items.size(), 1, std::max<uint32_t>(1, n / kMinRangePixels)));
        for (uint32_t r = 0; r < pieces; ++r)
          ranges.push_back({static_cast<uint32_t>(i), node.begin + uint32_t(uint64_t(n) * r / pieces),
                            node.begin + uint32_t(uint64_t(n) * (r + 1) / pieces)});
      }
      partial.resize(ranges.size());
      size_t level_bytes = 0;
      for (size_t i = 0; i < items.size(); ++i) level_bytes += groups[i].histogram_cells(info[items[i].node]) * 4 + sizeof(Candidate) * groups[i].candidates.size();
      for (const RangeItem& r : ranges) level_bytes += groups[r.group].histogram_cells(info[items[r.group].node]) * 4;
      range_peak_bytes = std::max(range_peak_bytes, level_bytes);
    }
    size_t node_parallel_nodes = 0;
    if (comm) {
      // Nodes below the switch are searched node-parallel, the others by histogram sums; either
      // search fills its items' results (the split does not depend on which).
      std::vector<Item> summed, gathered;
      std::vector<size_t> summed_at, gathered_at;
      for (size_t i = 0; i < items.size(); ++i) {
        const bool np = info[items[i].node].count < params.node_parallel_pixels;
        (np ? gathered : summed).push_back(items[i]);
        (np ? gathered_at : summed_at).push_back(i);
      }
      for (const NodeInfo& n : info) node_parallel_nodes += n.splittable && n.count < params.node_parallel_pixels;
      std::vector<Best> summed_results(summed.size()), gathered_results(gathered.size());
      search_distributed(grower, info, summed, summed_results, *comm, threads);
      search_node_parallel(grower, info, rank_counts, gathered, gathered_results, *comm, threads);
      for (size_t i = 0; i < summed.size(); ++i) results[summed_at[i]] = summed_results[i];
      for (size_t i = 0; i < gathered.size(); ++i) results[gathered_at[i]] = gathered_results[i];
    }
    const bool image_major =
        !comm && !by_ranges && !items.empty() && level >= replay_levels && grower.has_vector_kernel() &&
        std::all_of(items.begin(), items.end(),
                    [&](const Item& it) { return it.c0 == 0 && it.c1 == params.offset_candidates; });
    // A progress line every ~10 s within a long level (called on the calling thread only).
    auto heartbeat = [&](double done) {
      const auto now = std::chrono::steady_clock::now();
      if (!progress || now - last_beat <= std::chrono::seconds(10)) return;
      last_beat = now;
      LevelReport r;
      r.tree = tree_index;
      r.level = level;
      r.partial = true;
      r.done = done;
      r.seconds = std::chrono::duration<double>(now - level_start).count();
      r.tree_seconds = std::chrono::duration<double>(now - tree_start).count();
      progress(r);
    };
    if (image_major)
      search_image_major(grower, info, items, results, (params.offset_candidates + kLanes - 1) / kLanes * kLanes,
                         threads, params.level_feature_bytes ? params.level_feature_bytes : kLevelFeatureBytes,
                         level_rows, [&](size_t done) { heartbeat(double(done) / items.size()); });
    const size_t work = comm || image_major ? 0 : by_ranges ? ranges.size() : items.size();
    parallel_for(work, threads, [&](size_t i, int thread) {
      if (by_ranges) {
        const RangeItem& r = ranges[i];
        const NodeInfo& node = info[items[r.group].node];
        partial[i].assign(groups[r.group].histogram_cells(node), 0);
        grower.accumulate(node, groups[r.group], r.begin, r.end, partial[i].data(), thread);
      } else {
        results[i] = grower.evaluate(info[items[i].node], items[i].c0, items[i].c1, thread);
      }
      const size_t done = items_done.fetch_add(1) + 1;
      if (thread == 0) heartbeat(double(done) / work);
    });

    if (by_ranges) {
      std::vector<size_t> first_range(items.size() + 1, ranges.size());
      for (size_t i = ranges.size(); i-- > 0;) first_range[ranges[i].group] = i;
      parallel_for(items.size(), threads, [&](size_t g, int) {
        std::vector<uint32_t>& sum = partial[first_range[g]];
        for (size_t i = first_range[g] + 1; i < first_range[g + 1]; ++i) {
          for (size_t j = 0; j < sum.size(); ++j) sum[j] += partial[i][j];
          std::vector<uint32_t>().swap(partial[i]);
        }
        ScoreScratch scratch;
        results[g] = grower.score_group(info[items[g].node], groups[g], sum.data(), scratch);
      });
    }

    std::vector<size_t> splitting;
    if (level < replay_levels)
      for (size_t f : frontier)
        if (!nodes[f].leaf) splitting.push_back(f);
    for (size_t f = 0; f < info.size(); ++f) {
      Best best;
      for (size_t i = first_item[f]; i < first_item[f + 1]; ++i)
        if (results[i].candidate >= 0 && results[i].score < best.score) best = results[i];
      GrowNode& g = nodes[frontier[f]];
      const double parent = info[f].parent_score;
      if (best.candidate >= 0 && best.score < parent - 1e-12 * std::max(1.0, std::fabs(parent))) {
        g.leaf = false;
        g.du1 = best.du1;
        g.dv1 = best.dv1;
        g.du2 = best.du2;
        g.dv2 = best.dv2;
        g.threshold = best.threshold;
        splitting.push_back(frontier[f]);
      }
    }

    // Stable partition of each split node's pixels: left (feature ≤ threshold) then right.
    std::vector<uint32_t> left_counts(splitting.size());
    parallel_for(splitting.size(), threads, [&](size_t k, int) {
      const GrowNode& g = nodes[splitting[k]];
      Candidate c{};
      c.du1 = g.du1;
      c.dv1 = g.dv1;
      c.du2 = g.du2;
      c.dv2 = g.dv2;
      // One feature per pixel: the right side's pixels go to tmp in order, the left side's are
      // compacted in place (a write never overtakes the read), then the right side follows.
      uint32_t l = g.begin, r = g.begin;
      for (uint32_t i = g.begin; i < g.end; ++i) {
        if (feature_of_pixel(set, pixels[i], c) > g.threshold)
          tmp[r++] = pixels[i];
        else
          pixels[l++] = pixels[i];
      }
      left_counts[k] = l - g.begin;
      std::copy(tmp.begin() + g.begin, tmp.begin() + r, pixels.begin() + l);
    });
    std::vector<size_t> next;
    for (size_t k = 0; k < splitting.size(); ++k) {
      const GrowNode g = nodes[splitting[k]];
      const uint32_t mid = g.begin + left_counts[k];
      nodes.push_back({2 * g.heap + 1, g.begin, mid});
      next.push_back(nodes.size() - 1);
      nodes.push_back({2 * g.heap + 2, mid, g.end});
      next.push_back(nodes.size() - 1);
    }
    if (level < replay_levels) {
      frontier.swap(next);
      if (progress && level + 1 == replay_levels) {
        LevelReport r;
        r.tree = tree_index;
        r.level = level;
        r.resumed = true;
        r.tree_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tree_start).count();
        progress(r);
      }
      continue;
    }
    frontier.swap(next);

    const auto now = std::chrono::steady_clock::now();
    out.feature_evaluations += evaluations;
    if (progress) {
      LevelReport r;
      r.tree = tree_index;
      r.level = level;
      r.frontier_nodes = info.size();
      r.split_nodes = splitting.size();
      r.active_pixels = active;
      r.feature_evaluations = evaluations;
      r.bytes_reduced = comm ? comm->bytes_reduced() - reduced_before : 0;
      r.bytes_exchanged = comm ? comm->bytes_exchanged() - exchanged_before : 0;
      r.node_parallel_nodes = node_parallel_nodes;
      r.seconds = std::chrono::duration<double>(now - level_start).count();
      r.tree_seconds = std::chrono::duration<double>(now - tree_start).count();
      progress(r);
    }
    if (level_done) {
      GrowthState state;
      state.levels_done = level + 1;
      state.complete = frontier.empty();
      state.feature_evaluations = out.feature_evaluations;
      for (const GrowNode& g : nodes)
        if (heap_level(g.heap) <= level) state.nodes.push_back({g.heap, g.leaf, g.du1, g.dv1, g.du2, g.dv2, g.threshold});
      std::sort(state.nodes.begin(), state.nodes.end(),
                [](const DecidedNode& a, const DecidedNode& b) { return a.heap < b.heap; });
      level_done(state);
    }
  }

  if (resume && replay_next != resume->nodes.size())
    fail("checkpoint: tree " + std::to_string(tree_index) + " records " +
         std::to_string(resume->nodes.size() - replay_next) +
         " decisions for nodes the replayed tree does not have (the checkpoint belongs to other data or options)");
  std::sort(nodes.begin(), nodes.end(), [](const GrowNode& a, const GrowNode& b) { return a.heap < b.heap; });
  TrainedTree& tree = out.tree;
  for (const GrowNode& g : nodes) {
    TrainedNode n;
    n.heap_index = g.heap;
    if (g.leaf) {
      n.leaf = static_cast<int32_t>(out.leaf_ranges.size());
      out.leaf_ranges.push_back({g.begin, g.end});
      tree.leaf_pixel_counts.push_back(g.end - g.begin);
    } else {
      n.du1 = static_cast<int16_t>(g.du1);
      n.dv1 = static_cast<int16_t>(g.dv1);
      n.du2 = static_cast<int16_t>(g.du2);
      n.dv2 = static_cast<int16_t>(g.dv2);
      n.threshold_mm = static_cast<float>(std::clamp<int32_t>(g.threshold, -32768, 32767));
    }
    tree.nodes.push_back(n);
  }
  for (TrainedNode& n : tree.nodes) {
    if (n.is_leaf()) continue;
    auto position = [&](uint32_t heap) {
      return static_cast<int32_t>(std::lower_bound(tree.nodes.begin(), tree.nodes.end(), heap,
                                                   [](const TrainedNode& a, uint32_t h) { return a.heap_index < h; }) -
                                  tree.nodes.begin());
    };
    n.left = position(2 * n.heap_index + 1);
    n.right = position(2 * n.heap_index + 2);
  }
  out.peak_bytes = pixels.size() * sizeof(TrainingPixel) * 2 + grower.scratch_bytes() + range_peak_bytes +
                   level_rows.capacity() * sizeof(int16_t) + nodes.size() * sizeof(GrowNode);
  out.pixels = std::move(pixels);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tree_start).count();
  return out;
}

}  // namespace dp::train
