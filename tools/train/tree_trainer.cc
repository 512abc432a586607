#include "tools/train/tree_trainer.h"

#include <immintrin.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <cstdlib>
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
constexpr int kBlock = kMaxThresholds;  // pixels of a node's threshold sample
// Upper bound on one work item's classification histogram cells (uint32): 64k = 256 KiB, half of
// this machine's 512 KiB L2 per core, leaving the rest for the probe images' lines.
constexpr size_t kItemHistogramEntries = 65536;
// Pixels per range item at least, near the root (see grow_tree): enough that an item's fixed cost
// (zeroing and summing its partial histogram) stays small next to its feature evaluations.
constexpr uint32_t kMinRangePixels = 4096;
// Upper bound on a candidate group's histogram cells near the root: 256k = 1 MiB per range item;
// a pixel's increments stay within its class's bins × candidates block (≤ 64 KiB at 31 classes).
constexpr size_t kRangeHistogramEntries = 262144;

struct Candidate {
  int32_t du1, dv1, du2, dv2;
  int thresholds;        // unique, sorted
  int search_top;        // half the padded table size
  int32_t table[kMaxThresholds + 1];  // thresholds, then INT32_MAX
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
// per candidate, thresholds transposed ([threshold][candidate]) and padded with kNoThreshold, the
// count padded to a multiple of kLanes with inert candidates (zero offsets, no thresholds).
constexpr int kLanes = 16;                    // int16 lanes of an AVX2 register
constexpr int16_t kNoThreshold = 32767;       // above every feature (|feature| ≤ 32766)
struct CandidateLanes {
  int count = 0, padded = 0, thresholds = 0;  // thresholds = the most any candidate has
  std::vector<int32_t> du1, dv1, du2, dv2;
  std::vector<int16_t> table;                 // thresholds × padded
};

void make_lanes(const std::vector<Candidate>& candidates, CandidateLanes& l) {
  l.count = static_cast<int>(candidates.size());
  l.padded = (l.count + kLanes - 1) / kLanes * kLanes;
  l.thresholds = 0;
  for (const Candidate& c : candidates) l.thresholds = std::max(l.thresholds, c.thresholds);
  for (auto* v : {&l.du1, &l.dv1, &l.du2, &l.dv2}) v->assign(l.padded, 0);
  l.table.assign(size_t(l.thresholds) * l.padded, kNoThreshold);
  for (int c = 0; c < l.count; ++c) {
    const Candidate& cand = candidates[c];
    l.du1[c] = cand.du1;
    l.dv1[c] = cand.dv1;
    l.du2[c] = cand.du2;
    l.dv2[c] = cand.dv2;
    for (int t = 0; t < cand.thresholds; ++t) l.table[size_t(t) * l.padded + c] = static_cast<int16_t>(cand.table[t]);
  }
}

// A training image as the kernel reads it.
struct ImageRef {
  const uint16_t* probe;
  int32_t width, height;
};

// Features and bins of every candidate at one pixel (same values as dp::depth_feature and
// block_bins). Pixel-major: the pixel's neighbourhood stays in L1 while all candidates probe it,
// and consecutive pixels of a node mostly come from the same image (pixels stay in image order).
// A unary candidate (δ2 = 0) probes the pixel itself (offset 0 rounds to 0), which is its depth.
// Off-image probes load element 0 and OR in 0x7FFF: probe values are ≤ 32767, so the result is
// the background constant 32767 without a branch or select.
// Writes bin[0, l.padded); `feature` is scratch of l.padded entries. `l` is shared by threads
// (read only); feature and bin are the calling thread's.
inline void pixel_features(const CandidateLanes& l, const ImageRef& im, int32_t u, int32_t v, int32_t s,
                           int16_t* feature, int16_t* bin) {
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
  for (int c = 0; c < l.padded; c += 8) {
    const __m128i f = _mm_loadu_si128(reinterpret_cast<const __m128i*>(feature + c));
    __m128i count = _mm_setzero_si128();
    const int16_t* t = l.table.data() + c;
    for (int k = 0; k < l.thresholds; ++k, t += l.padded)
      count = _mm_sub_epi16(count, _mm_cmpgt_epi16(f, _mm_loadu_si128(reinterpret_cast<const __m128i*>(t))));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(bin + c), count);
  }
}

// One probe for 8 candidates (offset rows du, dv) at a pixel; see pixel_features_avx2.
struct ProbeAvx2 {
  __m256i vs, vu, vv, w, w1, h1, half, background, low16, ones;
  const int* base;
};
__attribute__((target("avx2"), always_inline)) inline __m256i probe_avx2(const ProbeAvx2& q, const int32_t* du,
                                                                          const int32_t* dv) {
  const __m256i pu = _mm256_add_epi32(
      q.vu, _mm256_srai_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(du)), q.vs), q.half),
                kScaleShift));
  const __m256i pv = _mm256_add_epi32(
      q.vv, _mm256_srai_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(dv)), q.vs), q.half),
                kScaleShift));
  // Sign bit set iff u < 0, v < 0, u > w − 1 or v > h − 1.
  const __m256i outside =
      _mm256_or_si256(_mm256_or_si256(pu, pv), _mm256_or_si256(_mm256_sub_epi32(q.w1, pu), _mm256_sub_epi32(q.h1, pv)));
  const __m256i index = _mm256_add_epi32(_mm256_mullo_epi32(pv, q.w), pu);
  const __m256i g = _mm256_mask_i32gather_epi32(q.background, q.base, index, _mm256_xor_si256(outside, q.ones), 2);
  return _mm256_and_si256(g, q.low16);
}

// The same as pixel_features, 8 candidates per AVX2 instruction for the offsets and bounds and
// 16 for the binning; probes are masked gathers of 32-bit words at the element's address whose low
// half is the element (little-endian; masked-off lanes keep the background). A gather may read the
// 2 bytes after an image's last element: heap blocks are allocated in 16-byte units, so they are
// inside the allocation's rounding or the allocator's next header, never unmapped.
__attribute__((target("avx2"))) void pixel_features_avx2(const CandidateLanes& l, const ImageRef& im, int32_t u,
                                                         int32_t v, int32_t s, int16_t*, int16_t* bin) {
  ProbeAvx2 q;
  q.vs = _mm256_set1_epi32(s);
  q.vu = _mm256_set1_epi32(u);
  q.vv = _mm256_set1_epi32(v);
  q.w = _mm256_set1_epi32(im.width);
  q.w1 = _mm256_set1_epi32(im.width - 1);
  q.h1 = _mm256_set1_epi32(im.height - 1);
  q.half = _mm256_set1_epi32(kScaleOneQ13 >> 1);
  q.background = _mm256_set1_epi32(kBackgroundDepthMm);
  q.low16 = _mm256_set1_epi32(0xFFFF);
  q.ones = _mm256_set1_epi32(-1);
  q.base = reinterpret_cast<const int*>(im.probe);
  for (int c = 0; c < l.padded; c += 16) {
    const __m256i f0 = _mm256_sub_epi32(probe_avx2(q, &l.du1[c], &l.dv1[c]), probe_avx2(q, &l.du2[c], &l.dv2[c]));
    const __m256i f1 =
        _mm256_sub_epi32(probe_avx2(q, &l.du1[c + 8], &l.dv1[c + 8]), probe_avx2(q, &l.du2[c + 8], &l.dv2[c + 8]));
    // packs interleaves 128-bit halves: [f0 0-3, f1 0-3, f0 4-7, f1 4-7] → reorder the quadwords.
    const __m256i f = _mm256_permute4x64_epi64(_mm256_packs_epi32(f0, f1), 0xD8);
    __m256i count = _mm256_setzero_si256();
    const int16_t* t = l.table.data() + c;
    for (int k = 0; k < l.thresholds; ++k, t += l.padded)
      count = _mm256_sub_epi16(count, _mm256_cmpgt_epi16(f, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t))));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(bin + c), count);
  }
}

// AVX2 when the CPU has it (same results: integer arithmetic throughout, tested against the
// forests of the scalar version).
using PixelFeaturesFn = void (*)(const CandidateLanes&, const ImageRef&, int32_t, int32_t, int32_t, int16_t*, int16_t*);
PixelFeaturesFn pick_pixel_features() {
  if (std::getenv("DEPTHPOSE_TRAIN_NO_AVX2") == nullptr && __builtin_cpu_supports("avx2")) return pixel_features_avx2;
  return pixel_features;
}

struct NodeInfo {
  uint32_t heap = 0;
  uint32_t begin = 0, end = 0;
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
};

struct Scratch {
  Block sample{};
  std::vector<Candidate> candidates;
  CandidateLanes lanes;
  std::vector<int16_t> feature, bin;  // one pixel's features and bins per candidate (pixel_features)
  std::vector<uint32_t> counts;   // classification histograms
  std::vector<double> sums;       // regression histograms
  std::vector<float> offsets;     // regression: block pixels × joints × {w, dx, dy, dz}
  std::vector<uint32_t> cum;
  std::vector<JointOffsetStats> left, right, total;
};

class Grower {
 public:
  struct CandidateGroup;
  Grower(const TrainingSet& set, std::vector<TrainingPixel>& pixels, int tree, const TreeParams& params)
      : set_(set), px_(pixels), tree_(tree), p_(params) {
    joints_ = static_cast<int>(set.joint_names.size());
    chunk_ = p_.objective == Objective::kClassification ? 16 : 4;
    features_ = pick_pixel_features();
    images_.reserve(set.images.size());
    for (const TrainingImage& im : set.images) images_.push_back({im.probe.data(), im.width, im.height});
    scratch_.resize(std::max(1, p_.threads));
    groups_.resize(std::max(1, p_.threads));
  }

  void pixel_offsets(const TrainingPixel& p, float* out) const {
    const TrainingImage& im = set_.images[p.image];
    const std::array<float, 3> x = pixel_point(im, p.u, p.v, p.depth_mm);
    const float rho2 = p_.rho_m * p_.rho_m;
    for (int j = 0; j < joints_; ++j) {
      const float dx = im.joints[3 * j] - x[0], dy = im.joints[3 * j + 1] - x[1], dz = im.joints[3 * j + 2] - x[2];
      const float w = dx * dx + dy * dy + dz * dz < rho2 ? 1.0f : 0.0f;
      out[4 * j] = w;
      out[4 * j + 1] = w * dx;
      out[4 * j + 2] = w * dy;
      out[4 * j + 3] = w * dz;
    }
  }

  void prepare(NodeInfo& node) const {
    const uint32_t n = node.end - node.begin;
    if (p_.objective == Objective::kClassification) {
      uint32_t counts[256] = {0};
      for (uint32_t i = node.begin; i < node.end; ++i) ++counts[px_[i].label];
      node.classes = 0;
      node.totals.clear();
      for (int l = 0; l < 256; ++l) {
        node.class_of[l] = 0;
        if (counts[l]) {
          node.class_of[l] = static_cast<uint8_t>(node.classes++);
          node.totals.push_back(counts[l]);
        }
      }
      node.parent_score = weighted_entropy(node.totals.data(), node.classes) / n;
      node.splittable = node.classes > 1;
    } else {
      std::vector<JointOffsetStats> st(joints_);
      std::vector<float> o(4 * joints_);
      for (uint32_t i = node.begin; i < node.end; ++i) {
        pixel_offsets(px_[i], o.data());
        for (int j = 0; j < joints_; ++j) {
          st[j].n += o[4 * j];
          st[j].sx += o[4 * j + 1];
          st[j].sy += o[4 * j + 2];
          st[j].sz += o[4 * j + 3];
          st[j].sq += double(o[4 * j + 1]) * o[4 * j + 1] + double(o[4 * j + 2]) * o[4 * j + 2] +
                      double(o[4 * j + 3]) * o[4 * j + 3];
        }
      }
      node.parent_score = sum_squared_deviation(st.data(), joints_) / n;
      node.splittable = node.parent_score > 1e-12;
    }
    node.splittable = node.splittable && node.level < p_.max_depth && n >= uint32_t(std::max(2, p_.min_samples));
  }

  // The node's threshold sample: min(n, |thresholds|) pixels drawn with replacement (key: seed,
  // tree, node), shared by all candidates of the node.
  void decode_sample(const NodeInfo& node, Block& b) const {
    Rng rng = Rng::keyed(p_.seed, 5, uint64_t(tree_), node.heap);
    const uint32_t n = node.end - node.begin;
    b.count = static_cast<int>(std::min<uint32_t>(n, std::min(p_.threshold_candidates, kMaxThresholds)));
    for (int i = 0; i < b.count; ++i) {
      const TrainingPixel& p = px_[node.begin + rng.below(n)];
      const TrainingImage& im = set_.images[p.image];
      b.image[i] = im.probe.data();
      b.width[i] = im.width;
      b.height[i] = im.height;
      b.u[i] = p.u;
      b.v[i] = p.v;
      b.scale[i] = p.scale_q13;
      b.depth[i] = p.depth_mm;
    }
  }

  void make_candidate(const NodeInfo& node, int index, Block& sample, Candidate& c) const {
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
    // Thresholds: the feature's values at the node's sample pixels (its response distribution).
    block_features(sample, c);
    const int wanted = sample.count;
    for (int i = 0; i < wanted; ++i) c.table[i] = sample.feature[i];
    std::sort(c.table, c.table + wanted);
    c.thresholds = static_cast<int>(std::unique(c.table, c.table + wanted) - c.table);
    int padded = 1;
    while (padded < c.thresholds + 1) padded *= 2;
    for (int i = c.thresholds; i < padded; ++i) c.table[i] = INT32_MAX;
    c.search_top = padded / 2;
  }

  // Evaluates candidates [c0, c1) of `node`; returns the best.
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
    for (int c = 0; c < c1 - c0; ++c) make_candidate(node, c0 + c, s.sample, g.candidates[c]);
    g.bins = 1;
    for (const Candidate& c : g.candidates) g.bins = std::max(g.bins, c.thresholds + 1);
    make_lanes(g.candidates, g.lanes);
  }

  // Classification: adds pixels [begin, end) of `node` to `counts`, cells [class][bin][candidate]
  // (histogram_cells of them): a pixel's increments for all candidates fall in its class's
  // bins × candidates block (a few kB, L1-resident). Integer counts: partial histograms over
  // disjoint pixel ranges sum to the same cells in any order (threads here; processes later).
  void accumulate(const NodeInfo& node, const CandidateGroup& g, uint32_t begin, uint32_t end, uint32_t* counts,
                  int thread) {
    const int nc = g.c1 - g.c0;
    const size_t class_stride = size_t(g.bins) * nc;
    const CandidateLanes& l = g.lanes;
    Scratch& s = scratch_[thread];
    s.feature.resize(l.padded);
    s.bin.resize(l.padded);
    int16_t* bin = s.bin.data();
    for (uint32_t i = begin; i < end; ++i) {
      const TrainingPixel& p = px_[i];
      features_(l, images_[p.image], p.u, p.v, p.scale_q13, s.feature.data(), bin);
      uint32_t* h = counts + node.class_of[p.label] * class_stride;
      for (int c = 0; c < nc; ++c) ++h[bin[c] * nc + c];
    }
  }

  // Classification: the best (candidate, threshold) of a group from its complete histogram.
  Best score_group(const NodeInfo& node, const CandidateGroup& g, const uint32_t* counts,
                   std::vector<uint32_t>& cum) const {
    const int k = node.classes, nc = g.c1 - g.c0, bins = g.bins;
    const uint32_t n = node.end - node.begin;
    Best best;
    cum.resize(k);
    for (int c = 0; c < nc; ++c) {
      const Candidate& cand = g.candidates[c];
      const uint32_t* h = counts + c;
      std::fill(cum.begin(), cum.end(), 0u);
      uint32_t left = 0;
      for (int t = 0; t < cand.thresholds; ++t) {
        uint32_t in_bin = 0;
        for (int j = 0; j < k; ++j) {
          const uint32_t cell = h[(size_t(j) * bins + t) * nc];
          cum[j] += cell;
          in_bin += cell;
        }
        left += in_bin;
        if (left == 0) continue;
        const uint32_t right = n - left;
        if (right == 0) break;
        // An empty bin leaves every count, hence the score, as at the previous threshold, which
        // cannot win a strict comparison against itself.
        if (in_bin == 0) continue;
        double wl = nlogn(left), wr = nlogn(right);
        for (int j = 0; j < k; ++j) {
          wl -= nlogn(cum[j]);
          wr -= nlogn(node.totals[j] - cum[j]);
        }
        const double score = (wl + wr) / n;
        if (score < best.score) {
          best.score = score;
          best.candidate = g.c0 + c;
          best.du1 = cand.du1;
          best.dv1 = cand.dv1;
          best.du2 = cand.du2;
          best.dv2 = cand.dv2;
          best.threshold = cand.table[t];
        }
      }
    }
    return best;
  }

  // Evaluates candidates [c0, c1) of `node` over all its pixels; returns the best.
  Best evaluate(const NodeInfo& node, int c0, int c1, int thread) {
    Scratch& s = scratch_[thread];
    if (p_.objective == Objective::kClassification) {
      CandidateGroup& g = groups_[thread];
      prepare_group(node, c0, c1, g, thread);
      s.counts.assign(g.histogram_cells(node), 0);
      accumulate(node, g, node.begin, node.end, s.counts.data(), thread);
      return score_group(node, g, s.counts.data(), s.cum);
    }
    const int nc = c1 - c0;
    s.candidates.resize(nc);
    decode_sample(node, s.sample);
    for (int c = 0; c < nc; ++c) make_candidate(node, c0 + c, s.sample, s.candidates[c]);
    int bins = 1;
    for (const Candidate& c : s.candidates) bins = std::max(bins, c.thresholds + 1);
    const uint32_t n = node.end - node.begin;
    Best best;
    {
      const int J = joints_;
      const size_t row = size_t(J) * 5;
      s.sums.assign(size_t(nc) * bins * row, 0.0);
      s.counts.assign(size_t(nc) * bins, 0);
      s.offsets.resize(size_t(J) * 4);
      make_lanes(s.candidates, s.lanes);
      const CandidateLanes& l = s.lanes;
      s.feature.resize(l.padded);
      s.bin.resize(l.padded);
      for (uint32_t i = node.begin; i < node.end; ++i) {
        const TrainingPixel& p = px_[i];
        features_(l, images_[p.image], p.u, p.v, p.scale_q13, s.feature.data(), s.bin.data());
        pixel_offsets(p, s.offsets.data());
        const float* o = s.offsets.data();
        for (int c = 0; c < nc; ++c) {
          const int bin = s.bin[c];
          ++s.counts[size_t(c) * bins + bin];
          double* hb = s.sums.data() + (size_t(c) * bins + bin) * row;
          for (int j = 0; j < J; ++j) {
            const double w = o[4 * j], dx = o[4 * j + 1], dy = o[4 * j + 2], dz = o[4 * j + 3];
            hb[5 * j] += w;
            hb[5 * j + 1] += dx;
            hb[5 * j + 2] += dy;
            hb[5 * j + 3] += dz;
            hb[5 * j + 4] += dx * dx + dy * dy + dz * dz;
          }
        }
      }
      s.left.resize(J);
      s.right.resize(J);
      s.total.resize(J);
      for (int c = 0; c < nc; ++c) {
        const Candidate& cand = s.candidates[c];
        const double* h = s.sums.data() + size_t(c) * bins * row;
        std::fill(s.total.begin(), s.total.end(), JointOffsetStats{});
        for (int t = 0; t <= cand.thresholds; ++t)
          for (int j = 0; j < J; ++j) add(s.total[j], h + t * row + 5 * j);
        std::fill(s.left.begin(), s.left.end(), JointOffsetStats{});
        const uint32_t* pixel_bins = s.counts.data() + size_t(c) * bins;
        uint32_t left = 0;
        for (int t = 0; t < cand.thresholds; ++t) {
          for (int j = 0; j < J; ++j) add(s.left[j], h + t * row + 5 * j);
          left += pixel_bins[t];
          if (left == 0) continue;
          const uint32_t right = n - left;
          if (right == 0) break;
          for (int j = 0; j < J; ++j) {
            s.right[j].n = s.total[j].n - s.left[j].n;
            s.right[j].sx = s.total[j].sx - s.left[j].sx;
            s.right[j].sy = s.total[j].sy - s.left[j].sy;
            s.right[j].sz = s.total[j].sz - s.left[j].sz;
            s.right[j].sq = s.total[j].sq - s.left[j].sq;
          }
          const double score = regression_objective(s.left.data(), s.right.data(), J, left, right);
          if (score < best.score) {
            best.score = score;
            best.candidate = c0 + c;
            best.du1 = cand.du1;
            best.dv1 = cand.dv1;
            best.du2 = cand.du2;
            best.dv2 = cand.dv2;
            best.threshold = cand.table[t];
          }
        }
      }
    }
    return best;
  }

  static void add(JointOffsetStats& s, const double* h) {
    s.n += h[0];
    s.sx += h[1];
    s.sy += h[2];
    s.sz += h[3];
    s.sq += h[4];
  }

  // Candidates per candidate group (work item) of `node` on a level with `splittable` nodes to
  // search. More candidates per group means each pixel's neighbourhood, once in cache, serves more
  // probes. Classification groups hold as many as keep the group's histogram within
  // kItemHistogramEntries (L2-resident), or kRangeHistogramEntries near the root (fewer than 8
  // nodes per thread), where groups are shared among threads by pixel ranges instead (grow_tree).
  // The chosen split does not depend on it (ties go to the lowest candidate across groups).
  int chunk_for(const NodeInfo& node, size_t splittable) const {
    if (p_.objective != Objective::kClassification) return chunk_;
    const size_t cap = splittable < size_t(8 * std::max(1, p_.threads)) ? kRangeHistogramEntries : kItemHistogramEntries;
    const size_t bins = size_t(std::min<uint32_t>(node.end - node.begin, p_.threshold_candidates)) + 1;
    const size_t fit = cap / (bins * std::max(1, node.classes));
    return static_cast<int>(std::max<size_t>(chunk_, fit / kLanes * kLanes));
  }

  size_t scratch_bytes() const {
    size_t b = 0;
    for (const Scratch& s : scratch_)
      b += sizeof(Scratch) + s.candidates.capacity() * sizeof(Candidate) + s.counts.capacity() * 4 +
           s.sums.capacity() * 8 + s.offsets.capacity() * 4;
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
  PixelFeaturesFn features_ = pixel_features;
  std::vector<Scratch> scratch_;
  std::vector<CandidateGroup> groups_;  // per thread, for evaluate()
};

struct GrowNode {
  uint32_t heap;
  uint32_t begin, end;
  bool leaf = true;
  int32_t du1 = 0, dv1 = 0, du2 = 0, dv2 = 0, threshold = 0;
};

}  // namespace

GrownTree grow_tree(const TrainingSet& set, std::vector<TrainingPixel> pixels, int tree_index,
                    const TreeParams& params, const ProgressFn& progress, const GrowthState* resume,
                    const LevelDoneFn& level_done) {
  const auto tree_start = std::chrono::steady_clock::now();
  if (pixels.empty()) fail("tree " + std::to_string(tree_index) + ": no training pixels");
  if (params.max_depth < 1 || params.max_depth > kMaxForestDepth)
    fail("--depth must be 1.." + std::to_string(kMaxForestDepth));
  if (params.offset_candidates < 1) fail("--offsets must be ≥ 1");
  if (params.threshold_candidates < 1 || params.threshold_candidates > kMaxThresholds)
    fail("--thresholds must be 1.." + std::to_string(kMaxThresholds));
  if (params.max_offset_pxm < 0 || params.max_offset_pxm > 4096) fail("--max-offset must be 0..4096 pixel·metres");
  if (params.objective == Objective::kClassification && !set.has_labels)
    fail("the classification objective needs part labels (datasets with parts/)");
  if (params.objective == Objective::kRegression && (!set.has_joints || set.joint_names.empty()))
    fail("the regression objective needs joints in every frame");
  if (pixels.size() > UINT32_MAX / 2) fail("too many training pixels for one tree");

  GrownTree out;
  Grower grower(set, pixels, tree_index, params);
  std::vector<TrainingPixel> tmp(pixels.size());
  std::vector<GrowNode> nodes;
  nodes.push_back({0, 0, static_cast<uint32_t>(pixels.size())});
  std::vector<size_t> frontier = {0};
  const int threads = std::max(1, params.threads);
  const int replay_levels = resume ? resume->levels_done : 0;
  size_t range_peak_bytes = 0;  // candidate groups and partial histograms of the range levels
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
    parallel_for(info.size(), threads, [&](size_t f, int) { grower.prepare(info[f]); });

    struct Item {
      uint32_t node;
      int c0, c1;
    };
    std::vector<Item> items;
    std::vector<size_t> first_item(info.size() + 1, 0);
    size_t splittable = 0;
    for (const NodeInfo& n : info) splittable += n.splittable;
    uint64_t evaluations = 0;
    size_t active = 0;
    for (size_t f = 0; f < info.size(); ++f) {
      first_item[f] = items.size();
      if (!info[f].splittable) continue;
      active += info[f].end - info[f].begin;
      evaluations += uint64_t(info[f].end - info[f].begin) * params.offset_candidates;
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
    const bool by_ranges = params.objective == Objective::kClassification && splittable > 0 &&
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
    const size_t work = by_ranges ? ranges.size() : items.size();
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
      if (thread == 0 && progress) {
        const auto now = std::chrono::steady_clock::now();
        if (now - last_beat > std::chrono::seconds(10)) {
          last_beat = now;
          LevelReport r;
          r.tree = tree_index;
          r.level = level;
          r.partial = true;
          r.done = double(done) / work;
          r.seconds = std::chrono::duration<double>(now - level_start).count();
          r.tree_seconds = std::chrono::duration<double>(now - tree_start).count();
          progress(r);
        }
      }
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
        std::vector<uint32_t> cum;
        results[g] = grower.score_group(info[items[g].node], groups[g], sum.data(), cum);
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
      uint32_t l = g.begin, r = g.begin;
      for (uint32_t i = g.begin; i < g.end; ++i)
        if (!(feature_of_pixel(set, pixels[i], c) > g.threshold)) ++r;
      left_counts[k] = r - g.begin;
      for (uint32_t i = g.begin; i < g.end; ++i) {
        if (feature_of_pixel(set, pixels[i], c) > g.threshold)
          tmp[r++] = pixels[i];
        else
          tmp[l++] = pixels[i];
      }
      std::copy(tmp.begin() + g.begin, tmp.begin() + g.end, pixels.begin() + g.begin);
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
                   nodes.size() * sizeof(GrowNode);
  out.pixels = std::move(pixels);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tree_start).count();
  return out;
}

}  // namespace dp::train
