#include <stdint.h>
#include <string.h>

#include <algorithm>
#include <x86intrin.h>

#include "runtime/arena.h"
#include "runtime/depthpose.h"
#include "runtime/fast_math.h"
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"
#include "runtime/kernels/mean_shift_kernel.h"
#include "runtime/kernels/vote_kernel.h"

namespace dp {

// Equal weights are common (uniform leaves, flat regions); breaking ties by casting order would keep
// only the first pixels in raster order and bias the subsample towards the top of the image, so ties
// are broken by a fixed hash of the order instead (deterministic, spatially unbiased).
static inline uint32_t tie_key(uint32_t order) {
  uint32_t x = order * 0x9E3779B1u;
  x ^= x >> 15;
  x *= 0x85EBCA77u;
  x ^= x >> 13;
  return x;
}
static inline bool lighter(const Vote& a, const Vote& b) {
  return a.weight < b.weight || (a.weight == b.weight && tie_key(a.order) < tie_key(b.order));
}

const char* status_message(Status s) {
  switch (s) {
    case Status::kOk: return "ok";
    case Status::kBadArgument: return "bad argument (null pointer, size or intrinsics)";
    case Status::kArenaTooSmall: return "arena smaller than minimum_arena_bytes()";
    case Status::kArenaMisaligned: return "arena not 64-byte aligned";
    case Status::kFrameTooLarge: return "frame larger than the maximum the pipeline was initialised for";
    case Status::kNotInitialized: return "pipeline not initialised";
    case Status::kBadConfig: return "runtime config value out of range";
    case Status::kKernelUnavailable: return "kernel not available on this CPU or build";
  }
  return "unknown status";
}

const char* stage_name(int32_t stage) {
  static const char* const names[kStageCount] = {"foreground", "forest", "votes", "mean_shift"};
  return stage >= 0 && stage < kStageCount ? names[stage] : "?";
}

namespace {

// Vote storage per joint: the reference keeps a top-N heap of at most Nsub ≤ kMaxVotesCap votes; the
// fast casters append up to 2·Nsub and select the top Nsub when full (amortized O(1) per vote).
constexpr int32_t kVoteSlots = 2 * blob::kMaxVotesCap;
// Mean-shift structure-of-arrays row: Nsub votes padded to a multiple of kMeanShiftLanes.
constexpr int32_t kSoaRow = blob::kMaxVotesCap + kernels::kMeanShiftLanes;
// Floor guess of the fast BPC caster: about kFloorSamples sampled pixels (at most twice that), their
// weights counted per joint in kGuessBuckets buckets of 1/8 octave (float bits >> 20) from
// 2^kGuessLowestExponent up; lighter weights (and 0) share bucket 0. Weights are ≤ 4096 (p ≤ 1,
// z ≤ 65.535 m), so the top bucket is never exceeded.
constexpr int32_t kFloorSamples = 512;
constexpr int32_t kMaxFloorSamples = 2 * kFloorSamples;
constexpr int32_t kGuessBuckets = 512;
constexpr int32_t kGuessPrefetchAhead = 8;  // samples
constexpr int32_t kGuessLowestKey = (127 + 13) * 8 - kGuessBuckets;  // (exponent + 127)·8 + top 3 mantissa bits
// OJR weights are a uint16 vote weight · z² (< 2^29): the same buckets, 16 octaves higher.
constexpr int32_t kGuessLowestKeyOjr = (127 + 29) * 8 - kGuessBuckets;

// Everything init carves, in one place so required_arena_bytes and init agree.
struct Layout {
  uint16_t* probe_image;
  EvaluatedPixel* pixels;
  uint32_t* leaves;
  Vote* votes;
  int32_t* vote_counts;
  Vote* starts;
  float* modes;
  float* soa;                         // mean shift: x, y, z, weight rows of kSoaRow floats
  uint64_t* select_keys;              // vote cut: 2·kVoteSlots uint32 (weight bits, boundary tie keys)
  uint16_t* guess_hist;               // floor guess: [kMaxJoints][kGuessBuckets] sample counts
  blob::RuntimeConfig* config;
  uint64_t* split_offsets;            // the split node copy (kernels::SplitTree); nullptr in a minimum arena
  int16_t* split_thresholds;
  uint16_t* joint_mass;               // BPC: per leaf record, Σ of its Q15 probabilities over each
                                      // joint's part mask (kMaxJoints lanes); nullptr when too large
};

// The per-leaf joint-mass table replaces 3·parts additions per pixel by 3 loads of 16 lanes; it is
// kept only while it is small (PCL: 25 records; a trained forest up to kMaxJointMassLeaves).
constexpr uint32_t kMaxJointMassLeaves = 1u << 18;  // 8 MB
bool use_joint_mass(const blob::LoadedBlob& b) {
  return b.method() == blob::Method::kBpc && b.meta->leaf_count <= kMaxJointMassLeaves;
}

// The SIMD kernels read split nodes (kernels::SplitTree: offsets and thresholds in two arrays) with
// the fewest ops per visit of the layouts measured (docs/runtime_speed.md, the layout study), for an
// arena copy of 10 bytes per node (shipped BPC: 2.0 MB; PCL's depth-20 trees: 31.5 MB). Without
// it (a minimum arena) they read the blob's 10-byte nodes in place.
bool carve(ArenaCarver& c, const blob::LoadedBlob& b, int32_t w, int32_t h, int32_t max_pixels, bool pack, Layout* l) {
  l->config = c.tail<blob::RuntimeConfig>(1);
  const size_t nodes = size_t(b.tree_count()) * blob::nodes_per_tree(b.depth());
  l->split_offsets = pack ? c.tail<uint64_t>(nodes) : nullptr;
  l->split_thresholds = pack ? c.tail<int16_t>(nodes) : nullptr;
  l->joint_mass = use_joint_mass(b) ? c.tail<uint16_t>(size_t(b.meta->leaf_count) * blob::kMaxJoints) : nullptr;
  l->probe_image = c.head<uint16_t>(kernels::padded_probe_elements(w, h));
  l->pixels = c.head<EvaluatedPixel>(size_t(max_pixels));
  l->leaves = c.head<uint32_t>(size_t(max_pixels) * size_t(b.tree_count()));
  l->votes = c.head<Vote>(size_t(blob::kMaxJoints) * kVoteSlots);
  l->vote_counts = c.head<int32_t>(blob::kMaxJoints);
  l->starts = c.head<Vote>(blob::kMaxStartsCap);
  l->modes = c.head<float>(size_t(blob::kMaxStartsCap) * 4);
  l->soa = c.head<float>(size_t(kSoaRow) * 4);
  l->select_keys = c.head<uint64_t>(size_t(kVoteSlots));
  l->guess_hist = c.head<uint16_t>(size_t(blob::kMaxJoints) * kGuessBuckets);
  return c.ok();
}

int32_t max_pixels_for(const blob::LoadedBlob& b, int32_t w, int32_t h) {
  const int64_t frame = int64_t(w) * h;
  const int64_t budget = b.config->max_evaluated_pixels;
  return int32_t(frame < budget ? frame : budget);
}

inline uint64_t cycles_now() { return __rdtsc(); }

// Min-heap on (weight, then later order) of at most `capacity` votes: keeps the top-N by weight.
void heap_sift_down(Vote* h, int32_t n, int32_t i) {
  for (;;) {
    int32_t l = 2 * i + 1, r = l + 1, m = i;
    if (l < n && lighter(h[l], h[m])) m = l;
    if (r < n && lighter(h[r], h[m])) m = r;
    if (m == i) return;
    Vote t = h[i]; h[i] = h[m]; h[m] = t;
    i = m;
  }
}
void heap_sift_up(Vote* h, int32_t i) {
  while (i > 0) {
    int32_t p = (i - 1) / 2;
    if (lighter(h[i], h[p])) {
      Vote t = h[i]; h[i] = h[p]; h[p] = t;
      i = p;
    } else {
      return;
    }
  }
}
// Returns true when the vote was dropped because the set was full (truncation happened).
inline bool push_top_n(Vote* heap, int32_t* count, int32_t capacity, const Vote& v) {
  if (*count < capacity) {
    heap[*count] = v;
    heap_sift_up(heap, (*count)++);
    return false;
  }
  if (lighter(heap[0], v)) {
    heap[0] = v;
    heap_sift_down(heap, *count, 0);
  }
  return true;
}

}  // namespace

namespace {
size_t arena_bytes_for(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height, bool pack) {
  if (!blob.meta || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return 0;
  ArenaCarver counter(nullptr, size_t(-1) / 2);
  Layout l;
  carve(counter, blob, max_width, max_height, max_pixels_for(blob, max_width, max_height), pack, &l);
  return counter.used();
}
}  // namespace

size_t required_arena_bytes(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height) {
  return arena_bytes_for(blob, max_width, max_height, true);
}
size_t minimum_arena_bytes(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height) {
  return arena_bytes_for(blob, max_width, max_height, false);
}

Status Pipeline::init(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height, uint8_t* arena,
                      size_t arena_bytes) {
  initialized_ = false;
  if (!blob.meta || !arena || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return Status::kBadArgument;
  if (reinterpret_cast<uintptr_t>(arena) % kArenaAlignment != 0) return Status::kArenaMisaligned;
  if (arena_bytes < minimum_arena_bytes(blob, max_width, max_height)) return Status::kArenaTooSmall;
  const bool pack = arena_bytes >= required_arena_bytes(blob, max_width, max_height);
  ArenaCarver c(arena, arena_bytes);
  Layout l;
  const int32_t max_pixels = max_pixels_for(blob, max_width, max_height);
  if (!carve(c, blob, max_width, max_height, max_pixels, pack, &l)) return Status::kArenaTooSmall;
  blob_ = blob;
  max_width_ = max_width;
  max_height_ = max_height;
  max_pixels_ = max_pixels;
  arena_ = arena;
  arena_bytes_ = arena_bytes;
  arena_used_ = c.used();
  probe_image_ = l.probe_image;
  pixels_ = l.pixels;
  leaves_ = l.leaves;
  votes_ = l.votes;
  vote_counts_ = l.vote_counts;
  starts_ = l.starts;
  modes_ = l.modes;
  config_ = l.config;
  *config_ = *blob.config;
  split_offsets_ = l.split_offsets;
  split_thresholds_ = l.split_thresholds;
  joint_mass_ = l.joint_mass;
  soa_ = l.soa;
  select_keys_ = l.select_keys;
  guess_hist_ = l.guess_hist;
  rebuild_joint_mass();
  if (split_offsets_) {
    const size_t per_tree = blob::nodes_per_tree(blob.depth());
    for (size_t i = 0; i < size_t(blob.tree_count()) * per_tree; ++i) {
      split_offsets_[i] = kernels::split_offsets_of(blob.nodes[i]);
      split_thresholds_[i] = blob.nodes[i].threshold_mm;
    }
  }
  evaluated_count_ = 0;
  kernel_ = forest_kernel_ = KernelIsa::kScalar;
  initialized_ = true;
  set_kernel(KernelIsa::kBest);
  return Status::kOk;
}

Status Pipeline::set_kernel(KernelIsa isa) {
  if (!kernel_isa_supported(isa)) return Status::kKernelUnavailable;
  if (isa == KernelIsa::kBest) {
    kernel_ = widest_kernel_isa();
    forest_kernel_ = best_forest_kernel_isa();
  } else {
    kernel_ = forest_kernel_ = isa;
  }
  return Status::kOk;
}

Status Pipeline::set_config(const blob::RuntimeConfig& config) {
  if (!initialized_) return Status::kNotInitialized;
  if (blob::validate_config(*blob_.meta, config) != blob::BlobStatus::kOk) return Status::kBadConfig;
  // The arena was sized for the blob's pixel budget; a larger one would overrun it.
  if (int64_t(config.max_evaluated_pixels) > int64_t(max_pixels_) &&
      int64_t(max_pixels_) < int64_t(max_width_) * max_height_)
    return Status::kBadConfig;
  *config_ = config;
  rebuild_joint_mass();
  return Status::kOk;
}

void Pipeline::rebuild_joint_mass() {
  if (!joint_mass_) return;
  const int parts = blob_.meta->part_count;
  for (uint32_t l = 0; l < blob_.meta->leaf_count; ++l) {
    const uint16_t* p = blob_.bpc_leaf(l);
    uint16_t* out = joint_mass_ + size_t(l) * blob::kMaxJoints;
    for (int j = 0; j < blob::kMaxJoints; ++j) {
      uint32_t mass = 0;
      if (j < blob_.meta->joint_count)
        for (uint32_t m = config_->joints[j].part_mask; m; m &= m - 1)
          if (int(__builtin_ctz(m)) < parts) mass += p[__builtin_ctz(m)];
      out[j] = uint16_t(mass);  // Σ ≤ 32768 (validated at load)
    }
  }
}

void Pipeline::part_distribution(int32_t i, uint16_t* out) const {
  const int parts = blob_.meta->part_count;
  const int trees = blob_.tree_count();
  uint32_t acc[blob::kMaxParts] = {};
  for (int t = 0; t < trees; ++t) {
    const uint16_t* p = blob_.bpc_leaf(leaf_of(i, t));
    for (int c = 0; c < parts; ++c) acc[c] += p[c];
  }
  for (int c = 0; c < parts; ++c) out[c] = uint16_t(acc[c] / uint32_t(trees));
}

Status Pipeline::process(const DepthFrame& f, FrameResult* r) {
  if (!r) return Status::kBadArgument;
  memset(r, 0, sizeof *r);
  if (!initialized_) return Status::kNotInitialized;
  if (!f.depth_mm || f.width < 1 || f.height < 1 || f.stride_px < f.width || !(f.intrinsics.fx > 0.0f) ||
      !(f.intrinsics.fy > 0.0f))
    return Status::kBadArgument;
  if (f.width > max_width_ || f.height > max_height_) return Status::kFrameTooLarge;
  const blob::RuntimeConfig& cfg = *config_;
  r->joint_count = blob_.meta->joint_count;
  const uint64_t t0 = cycles_now();

  // Stage 1: foreground → probe image and the (possibly strided) list of pixels to evaluate.
  const int32_t w = f.width, h = f.height;
  const int32_t probe_stride = w + 2;
  kernels::fill_probe_border(probe_image_, w, h);
  // One pass writes the probe image, counts the foreground and lists it in raster order (what an
  // unstrided frame evaluates); a frame over its pixel budget is listed again with a stride below.
  // Eight pixels at a time: unsigned 16-bit range tests as min/max equalities (SSE4.1).
  const int32_t pixel_cap = int32_t(cfg.max_evaluated_pixels) < max_pixels_ ? int32_t(cfg.max_evaluated_pixels) : max_pixels_;
  int32_t fg = 0, listed = 0;
  const __m128i zero = _mm_setzero_si128(), bg = _mm_set1_epi16(int16_t(kBackgroundDepthMm));
  const __m128i bias = _mm_set1_epi16(int16_t(kernels::kProbeBias));  // kernels::probe_element
  const __m128i below_bg = _mm_set1_epi16(int16_t(kBackgroundDepthMm - 1));
  const __m128i near = _mm_set1_epi16(int16_t(cfg.near_mm)), far = _mm_set1_epi16(int16_t(cfg.far_mm));
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const uint8_t* mrow = f.foreground_mask ? f.foreground_mask + size_t(v) * f.stride_px : nullptr;
    uint16_t* out = probe_image_ + size_t(v + 1) * probe_stride + 1;
    // Foreground lanes are −1: subtracting them counts the row in 8 lanes (≤ 512 each), summed once
    // per row. (popcount would be a libgcc call at the SSE4.1 baseline, which has no POPCNT.)
    __m128i row_count = zero;
    int32_t u = 0;
    for (; u + 8 <= w; u += 8) {
      const __m128i z = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + u));
      __m128i in = _mm_andnot_si128(_mm_cmpeq_epi16(z, zero), _mm_cmpeq_epi16(_mm_min_epu16(z, below_bg), z));
      if (mrow) {
        const __m128i m = _mm_cvtepu8_epi16(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(mrow + u)));
        in = _mm_andnot_si128(_mm_cmpeq_epi16(m, zero), in);
      } else {
        in = _mm_and_si128(in, _mm_and_si128(_mm_cmpeq_epi16(_mm_max_epu16(z, near), z),
                                             _mm_cmpeq_epi16(_mm_min_epu16(z, far), z)));
      }
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + u), _mm_or_si128(_mm_blendv_epi8(bg, z, in), bias));
      row_count = _mm_sub_epi16(row_count, in);
      uint32_t bits = uint32_t(_mm_movemask_epi8(_mm_packs_epi16(in, zero)));
      for (; bits && listed < pixel_cap; bits &= bits - 1) {
        const int32_t x = u + __builtin_ctz(bits);
        pixels_[listed++] = EvaluatedPixel{uint16_t(x), uint16_t(v), row[x], 0};
      }
    }
    const __m128i pairs = _mm_madd_epi16(row_count, _mm_set1_epi16(1));
    const __m128i sum2 = _mm_add_epi32(pairs, _mm_shuffle_epi32(pairs, _MM_SHUFFLE(1, 0, 3, 2)));
    fg += _mm_cvtsi128_si32(_mm_add_epi32(sum2, _mm_shuffle_epi32(sum2, _MM_SHUFFLE(2, 3, 0, 1))));
    for (; u < w; ++u) {
      const uint16_t z = row[u];
      const bool is_fg = z != 0 && z < kBackgroundDepthMm &&
                         (mrow ? mrow[u] != 0 : (z >= cfg.near_mm && z <= cfg.far_mm));
      out[u] = kernels::probe_element(is_fg ? z : kBackgroundDepthMm);
      fg += is_fg;
      if (is_fg && listed < pixel_cap) pixels_[listed++] = EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0};
    }
  }
  r->foreground_pixels = fg;
  int32_t budget = pixel_cap;
  plan_budget(w * h, fg, pixel_cap, &budget, r);
  int32_t stride = 1;
  if (fg > budget) {
    stride = (fg + budget - 1) / budget;
    r->flags |= kFlagPixelsStrided;
  }
  r->pixel_stride = stride;
  int32_t n = fg;
  if (fg > budget) {
    n = 0;
    int32_t seen = 0;
    for (int32_t v = 0; v < h && n < budget; ++v) {
      const uint16_t* row = probe_image_ + size_t(v + 1) * probe_stride + 1;
      for (int32_t u = 0; u < w; ++u) {
        const int32_t z = kernels::probe_depth_of(row[u]);
        if (z == kBackgroundDepthMm) continue;
        if (seen++ % stride != 0) continue;
        if (n >= budget) break;
        pixels_[n++] = EvaluatedPixel{uint16_t(u), uint16_t(v), uint16_t(z), 0};
      }
    }
  }
  evaluated_count_ = n;
  r->evaluated_pixels = n;
  const uint64_t t1 = cycles_now();
  r->stage_cycles[kStageForeground] = t1 - t0;
  if (n == 0) {
    r->flags |= kFlagNoForeground;
    r->total_cycles = t1 - t0;
    return Status::kOk;
  }

  // Stage 2: the forest.
  const float fref = blob_.meta->reference_focal_px;
  const int32_t focal = focal_factor_mm(0.5f * (f.intrinsics.fx + f.intrinsics.fy), fref);
  kernels::ForestKernelArgs per_tree[blob::kMaxTrees];
  kernels::SplitTree split[blob::kMaxTrees];
  for (int t = 0; t < blob_.tree_count(); ++t) {
    const size_t first = size_t(t) * blob::nodes_per_tree(blob_.depth());
    if (split_offsets_) split[t] = kernels::SplitTree{split_offsets_ + first, split_thresholds_ + first};
    per_tree[t] = kernels::ForestKernelArgs{probe_image_, probe_stride, w, h, focal, pixels_, n, blob_.tree_nodes(t),
                                            nullptr, blob_.tree_leaf_index(t), blob_.depth(),
                                            leaves_ + size_t(t) * max_pixels_, split_offsets_ ? &split[t] : nullptr};
  }
  kernels::forest_trees_kernel(forest_kernel_)(per_tree, blob_.tree_count());
  const uint64_t t2 = cycles_now();
  r->stage_cycles[kStageForest] = t2 - t1;

  // Stage 3: votes.
  for (int j = 0; j < blob::kMaxJoints; ++j) vote_counts_[j] = 0;
  cast_votes(f, r);
  const uint64_t t3 = cycles_now();
  r->stage_cycles[kStageVotes] = t3 - t2;

  // Stage 4: mean shift.
  aggregate(r);
  const uint64_t t4 = cycles_now();
  r->stage_cycles[kStageMeanShift] = t4 - t3;
  r->total_cycles = t4 - t0;
  if (cfg.cycle_budget != 0 && r->total_cycles > cfg.cycle_budget) r->flags |= kFlagOverCycleBudget;
  return Status::kOk;
}

// The worst-case cost model of docs/budget.md, in TSC cycles. It is deliberately the same for every
// forest kernel (calibrated on the fastest), so a budget degrades a frame identically whichever
// kernel runs, and results stay bit-identical across kernels; a slower kernel overruns and says so.
namespace budget_model {
constexpr uint64_t kPerFramePixel = 3;      // foreground scan, per frame pixel
constexpr uint64_t kPerNodeVisit = 5;       // forest, per pixel × tree × level
constexpr uint64_t kPerBpcPixel = 60;       // BPC votes, per evaluated pixel
constexpr uint64_t kPerOjrVote = 8;         // OJR votes, per pixel × tree × joint × K
constexpr uint64_t kPerKernelEval = 3;      // mean shift, per start × iteration × vote (4 lanes)
constexpr uint64_t kPerJoint = 20000;       // aggregation fixed cost per joint (sort, modes)
constexpr int32_t kMinPixels = 1000;        // degrade floors (or the configured value if lower)
constexpr int32_t kMinVotes = 32;
constexpr int32_t kMinStarts = 4;
constexpr int32_t kMinIterations = 2;
}  // namespace budget_model

void Pipeline::plan_budget(int32_t frame_pixels, int32_t fg, int32_t pixel_cap, int32_t* pixels,
                           FrameResult* r) const {
  namespace bm = budget_model;
  const blob::RuntimeConfig& cfg = *config_;
  const blob::ForestMeta& m = *blob_.meta;
  int64_t n = fg < pixel_cap ? fg : pixel_cap;
  int64_t votes = cfg.max_votes_per_joint, starts = cfg.max_starts_per_joint, iters = cfg.mean_shift_iterations;
  const int64_t joints = m.joint_count;
  const uint64_t per_pixel = bm::kPerNodeVisit * uint64_t(m.tree_count) * m.depth +
                             (blob_.method() == blob::Method::kBpc
                                  ? bm::kPerBpcPixel
                                  : bm::kPerOjrVote * uint64_t(m.tree_count) * uint64_t(joints) * m.votes_per_joint);
  const uint64_t fixed = bm::kPerFramePixel * uint64_t(frame_pixels) + bm::kPerJoint * uint64_t(joints);
  auto mean_shift = [&](int64_t v, int64_t s, int64_t it) { return bm::kPerKernelEval * uint64_t(joints * s * it * ((v + 3) & ~3)); };
  auto total = [&]() { return fixed + per_pixel * uint64_t(n) + mean_shift(votes, starts, iters); };
  const uint64_t budget = cfg.cycle_budget;
  if (budget != 0 && total() > budget) {
    // 1. pixels (stride), down to the floor.
    const int64_t floor_n = n < bm::kMinPixels ? n : bm::kMinPixels;
    const uint64_t rest = fixed + mean_shift(votes, starts, iters);
    const int64_t fit = budget > rest ? int64_t((budget - rest) / per_pixel) : 0;
    const int64_t new_n = fit > floor_n ? fit : floor_n;
    if (new_n < n) { n = new_n; r->flags |= kFlagBudgetPixels; }
    // 2.–4. Nsub, starts, iterations, each down to its floor while still over.
    int64_t* knobs[3] = {&votes, &starts, &iters};
    const int64_t floors[3] = {bm::kMinVotes, bm::kMinStarts, bm::kMinIterations};
    const uint32_t flags[3] = {kFlagBudgetVotes, kFlagBudgetStarts, kFlagBudgetIterations};
    for (int k = 0; k < 3 && total() > budget; ++k) {
      int64_t& knob = *knobs[k];
      const int64_t lowest = knob < floors[k] ? knob : floors[k];
      const int64_t original = knob;
      while (knob > lowest && total() > budget) knob = knob - 1 - (knob - lowest) / 8;  // ~12% steps
      if (knob < lowest) knob = lowest;
      if (knob < original) r->flags |= flags[k];
    }
    if (total() > budget) r->flags |= kFlagBudgetInfeasible;
  }
  *pixels = int32_t(n > 0 ? n : 1);
  r->votes_per_joint_used = int32_t(votes);
  r->starts_per_joint_used = int32_t(starts);
  r->iterations_used = int32_t(iters);
  r->predicted_cycles = total();
}

Status Pipeline::process_user(const DepthFrame& f, uint8_t user_id, FrameResult* r) {
  if (!r) return Status::kBadArgument;
  memset(r, 0, sizeof *r);
  if (!initialized_) return Status::kNotInitialized;
  if (!f.foreground_mask || user_id == 0 || f.stride_px < f.width || f.width > max_width_ || f.height > max_height_)
    return Status::kBadArgument;
  r->joint_count = blob_.meta->joint_count;
  const uint64_t t0 = cycles_now();
  int32_t mine = 0;
  for (int32_t i = 0; i < evaluated_count_; ++i)
    mine += f.foreground_mask[size_t(pixels_[i].v) * size_t(f.stride_px) + pixels_[i].u] == user_id;
  r->evaluated_pixels = mine;
  if (mine == 0) {
    r->flags |= kFlagNoForeground;
    r->total_cycles = cycles_now() - t0;
    return Status::kOk;
  }
  user_filter_ = f.foreground_mask;
  user_filter_stride_ = f.stride_px;
  user_filter_id_ = user_id;
  // No cycle-budget plan here: the frame's own process() already planned; its limits apply as configured.
  r->votes_per_joint_used = config_->max_votes_per_joint;
  r->starts_per_joint_used = config_->max_starts_per_joint;
  r->iterations_used = config_->mean_shift_iterations;
  for (int j = 0; j < blob::kMaxJoints; ++j) vote_counts_[j] = 0;
  cast_votes(f, r);
  user_filter_ = nullptr;
  const uint64_t t1 = cycles_now();
  aggregate(r);
  const uint64_t t2 = cycles_now();
  r->stage_cycles[kStageVotes] = t1 - t0;
  r->stage_cycles[kStageMeanShift] = t2 - t1;
  r->total_cycles = t2 - t0;
  return Status::kOk;
}

Status Pipeline::aggregate_from_leaves(const CameraIntrinsics& intr, const EvaluatedPixel* pixels,
                                       const uint32_t* leaves, int32_t count, FrameResult* r) {
  if (!r) return Status::kBadArgument;
  memset(r, 0, sizeof *r);
  if (!initialized_) return Status::kNotInitialized;
  if (!pixels || !leaves || count < 1 || count > max_pixels_ || !(intr.fx > 0.0f) || !(intr.fy > 0.0f))
    return Status::kBadArgument;
  const int trees = blob_.tree_count();
  for (size_t k = 0; k < size_t(count) * size_t(trees); ++k)
    if (leaves[k] >= blob_.meta->leaf_count) return Status::kBadArgument;
  const uint64_t t0 = cycles_now();
  memcpy(pixels_, pixels, size_t(count) * sizeof(EvaluatedPixel));
  for (int t = 0; t < trees; ++t)
    memcpy(leaves_ + size_t(t) * max_pixels_, leaves + size_t(t) * count, size_t(count) * sizeof(uint32_t));
  evaluated_count_ = count;
  r->joint_count = blob_.meta->joint_count;
  r->evaluated_pixels = count;
  r->foreground_pixels = count;
  r->pixel_stride = 1;
  // No cycle-budget plan here (the frame size is unknown): the config's limits apply as they are.
  r->votes_per_joint_used = config_->max_votes_per_joint;
  r->starts_per_joint_used = config_->max_starts_per_joint;
  r->iterations_used = config_->mean_shift_iterations;
  const DepthFrame f{nullptr, 0, 0, 0, intr, nullptr};  // the vote casters read only the intrinsics
  for (int j = 0; j < blob::kMaxJoints; ++j) vote_counts_[j] = 0;
  cast_votes(f, r);
  const uint64_t t1 = cycles_now();
  r->stage_cycles[kStageVotes] = t1 - t0;
  aggregate(r);
  const uint64_t t2 = cycles_now();
  r->stage_cycles[kStageMeanShift] = t2 - t1;
  r->total_cycles = t2 - t0;
  return Status::kOk;
}

void Pipeline::cast_bpc_votes(const DepthFrame& f, FrameResult* r) {
  const blob::RuntimeConfig& cfg = *config_;
  const int joints = blob_.meta->joint_count;
  const int trees = blob_.tree_count();
  const int parts = blob_.meta->part_count;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  const float inv_total = 1.0f / (32768.0f * float(trees));
  const int32_t cap = r->votes_per_joint_used;
  // Lightest kept weight per joint once its top-N set is full: lighter votes are rejected before
  // any work (exactly push_top_n's own rejection), which is the common case on large frames.
  float floor_weight[blob::kMaxJoints];
  for (int j = 0; j < blob::kMaxJoints; ++j) floor_weight[j] = -1.0f;
  for (int32_t i = 0; i < evaluated_count_; ++i) {
    const EvaluatedPixel px = pixels_[i];
    if (skipped_by_user_filter(px)) continue;
    uint32_t mass[blob::kMaxJoints] = {};
    if (joint_mass_) {
      for (int t = 0; t < trees; ++t) {
        const uint16_t* m = joint_mass_ + size_t(leaf_of(i, t)) * blob::kMaxJoints;
        for (int j = 0; j < blob::kMaxJoints; ++j) mass[j] += m[j];
      }
    } else {
      uint32_t acc[blob::kMaxParts] = {};
      for (int t = 0; t < trees; ++t) {
        const uint16_t* p = blob_.bpc_leaf(leaf_of(i, t));
        for (int c = 0; c < parts; ++c) acc[c] += p[c];
      }
      for (int j = 0; j < joints; ++j)
        for (uint32_t m = cfg.joints[j].part_mask; m; m &= m - 1) mass[j] += acc[__builtin_ctz(m)];
    }
    const float z = float(px.z_mm) * 0.001f;
    const float x = (float(px.u) - f.intrinsics.cx) * z * inv_fx;
    const float y = -(float(px.v) - f.intrinsics.cy) * z * inv_fy;
    for (int j = 0; j < joints; ++j) {
      if (mass[j] == 0) continue;
      const float p = float(mass[j]) * inv_total;
      const float weight = p * z * z;
      if (weight < floor_weight[j]) {
        r->flags |= kFlagVotesTruncated;
        continue;
      }
      const blob::JointConfig& jc = cfg.joints[j];
      Vote v{x, y, z + float(jc.push_back_mm) * 0.001f, weight, uint32_t(i),
             uint32_t(uint64_t(mass[j]) > uint64_t(jc.prob_threshold_q15) * uint64_t(trees) ? 1 : 0)};
      Vote* heap = votes_ + size_t(j) * kVoteSlots;
      if (push_top_n(heap, &vote_counts_[j], cap, v)) r->flags |= kFlagVotesTruncated;
      if (vote_counts_[j] == cap) floor_weight[j] = heap[0].weight;
    }
  }
}

void Pipeline::cast_ojr_votes(const DepthFrame& f, FrameResult* r) {
  const blob::RuntimeConfig& cfg = *config_;
  const int joints = blob_.meta->joint_count;
  const int trees = blob_.tree_count();
  const int k_votes = blob_.meta->votes_per_joint;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  const int32_t cap = r->votes_per_joint_used;
  float floor_weight[blob::kMaxJoints];
  int64_t len2[blob::kMaxJoints];
  for (int j = 0; j < blob::kMaxJoints; ++j) {
    floor_weight[j] = -1.0f;
    const int64_t len = cfg.joints[j].vote_length_mm;
    len2[j] = len == 0 ? INT64_MAX : len * len;
  }
  for (int32_t i = 0; i < evaluated_count_; ++i) {
    const EvaluatedPixel px = pixels_[i];
    if (skipped_by_user_filter(px)) continue;
    const float z = float(px.z_mm) * 0.001f;
    const float z2 = z * z;
    const float x = (float(px.u) - f.intrinsics.cx) * z * inv_fx;
    const float y = -(float(px.v) - f.intrinsics.cy) * z * inv_fy;
    for (int t = 0; t < trees; ++t) {
      const blob::OjrVote* leaf = blob_.ojr_leaf(leaf_of(i, t));
      for (int j = 0; j < joints; ++j) {
        for (int k = 0; k < k_votes; ++k) {
          const blob::OjrVote& ov = leaf[j * k_votes + k];
          if (ov.weight == 0) continue;
          const int64_t d2 = int64_t(ov.dx_mm) * ov.dx_mm + int64_t(ov.dy_mm) * ov.dy_mm + int64_t(ov.dz_mm) * ov.dz_mm;
          if (d2 > len2[j]) continue;
          const float weight = float(ov.weight) * z2;
          if (weight < floor_weight[j]) {
            r->flags |= kFlagVotesTruncated;
            continue;
          }
          // The order depends on (pixel, tree, k) only, never on other joints' vote-length filters:
          // each joint's proposals depend only on its own JointConfig (tune relies on this).
          const uint32_t order = (uint32_t(i) * uint32_t(trees) + uint32_t(t)) * uint32_t(k_votes) + uint32_t(k);
          Vote v{x + float(ov.dx_mm) * 0.001f, y + float(ov.dy_mm) * 0.001f, z + float(ov.dz_mm) * 0.001f, weight,
                 order, 1};
          Vote* heap = votes_ + size_t(j) * kVoteSlots;
          if (push_top_n(heap, &vote_counts_[j], cap, v)) r->flags |= kFlagVotesTruncated;
          if (vote_counts_[j] == cap) floor_weight[j] = heap[0].weight;
        }
      }
    }
  }
}

void Pipeline::cast_votes(const DepthFrame& f, FrameResult* r) {
  const bool bpc = blob_.method() == blob::Method::kBpc;
  if (kernel_ == KernelIsa::kScalar) {
    if (bpc) cast_bpc_votes(f, r); else cast_ojr_votes(f, r);
  } else {
    if (bpc) cast_bpc_votes_fast(f, r); else cast_ojr_votes_fast(f, r);
  }
}

// The fast casters below keep exactly the votes of the reference casters above. Why that holds:
// a candidate's weight is computed by the same float operations in the same order (SIMD lanes are
// IEEE single like the scalar code, and no multiply-add is fused); the kept set is the top Nsub
// under the same total order (weight, then tie_key(order)), which is unique, so it does not matter
// that the reference finds it with a heap and these with buffered selection; a floor only pre-filters
// votes lighter than it, and the kept set is proven to lie at or above every floor used (the BPC
// guess is verified after the scan). The buffers stay in casting order (every cut compacts stably),
// so aggregate() needs no sort after them.
// Speed (docs/runtime_speed.md): the BPC caster guesses each joint's final floor from a sample of
// the pixels first, so most candidates are rejected by one SIMD compare per pixel instead of being
// appended and cut; the joint-mass rows / OJR leaves of pixels a few ahead are prefetched (random
// reads in tables beyond L1).
constexpr int32_t kVotePrefetchAhead = kernels::kVotePrefetchAhead;  // pixels

namespace {
// Weights are ≥ 0, and non-negative floats order like their bit patterns.
inline uint32_t weight_bits(float w) {
  uint32_t bits;
  memcpy(&bits, &w, sizeof bits);
  return bits;
}
}  // namespace

// Cuts joint j's buffer to its cap heaviest votes under (weight, then tie_key(order)) — the
// reference heap's set, unique because orders are unique and tie_key is a bijection — keeping
// their casting order; returns the lightest kept weight (the joint's floor from now on). The
// selection runs on weight bits alone and hashes orders only for the votes tied at the boundary.
float Pipeline::cut_votes(int j, int32_t cap) {
  Vote* buf = votes_ + size_t(j) * kVoteSlots;
  const int32_t n = vote_counts_[j];
  uint32_t* const bits = reinterpret_cast<uint32_t*>(select_keys_);  // [kVoteSlots]
  uint32_t* const ties = bits + kVoteSlots;                          // [kVoteSlots]
  for (int32_t i = 0; i < n; ++i) bits[i] = weight_bits(buf[i].weight);
  std::nth_element(bits, bits + (n - cap), bits + n);
  const uint32_t boundary = bits[n - cap];  // the cap-th heaviest weight
  int32_t heavier = 0, tied = 0;
  for (int32_t i = 0; i < n; ++i) {
    const uint32_t w = weight_bits(buf[i].weight);
    heavier += w > boundary;
    if (w == boundary) ties[tied++] = tie_key(buf[i].order);
  }
  const int32_t need = cap - heavier;  // 1..tied votes of the boundary weight are kept
  uint32_t lightest_tie = 0;           // keep boundary votes whose tie key is ≥ this
  if (need < tied) {
    std::nth_element(ties, ties + (tied - need), ties + tied);
    lightest_tie = ties[tied - need];
  }
  int32_t out = 0;
  for (int32_t i = 0; i < n; ++i) {
    const uint32_t w = weight_bits(buf[i].weight);
    if (w > boundary || (w == boundary && tie_key(buf[i].order) >= lightest_tie)) buf[out++] = buf[i];
  }
  vote_counts_[j] = out;
  float floor;
  memcpy(&floor, &boundary, sizeof floor);
  return floor;
}

// Appends v to joint j's buffer; when 2·cap votes are held, keeps the cap heaviest and raises
// *floor_weight to the lightest of them. Returns true when votes were dropped.
bool Pipeline::append_vote(int j, int32_t cap, const Vote& v, float* floor_weight) {
  Vote* buf = votes_ + size_t(j) * kVoteSlots;
  int32_t& n = vote_counts_[j];
  buf[n++] = v;
  if (n < 2 * cap) return false;
  *floor_weight = cut_votes(j, cap);
  return true;
}

// Cuts every joint's buffer to its cap heaviest votes. Returns true when votes were dropped.
bool Pipeline::finish_votes(int32_t cap) {
  bool dropped = false;
  for (int j = 0; j < blob::kMaxJoints; ++j) {
    if (vote_counts_[j] <= cap) continue;
    cut_votes(j, cap);
    dropped = true;
  }
  return dropped;
}

namespace {
// The lower edge of the highest bucket of `hist` (kGuessBuckets of 1/8 octave from lowest_key) at
// which `rank` samples are reached from above, or −1 (no guess) when the rank falls to bucket 0.
float floor_at_rank(const uint16_t* hist, int32_t rank, int32_t lowest_key) {
  int32_t above = 0, b = kGuessBuckets - 1;
  for (; b > 0; --b)
    if ((above += hist[b]) >= rank) break;
  if (b == 0) return -1.0f;
  const uint32_t bits = uint32_t(b + lowest_key) << 20;
  float edge;
  memcpy(&edge, &bits, sizeof bits);
  return edge;
}
}  // namespace

// A guess of each joint's final floor: about the weight that 2·cap candidates reach, estimated on
// every k-th pixel (k ≈ pixels / kFloorSamples) and rounded down to its 1/8-octave bucket. A guess
// may be wrong either way; too low costs appends, too high is caught by cast_bpc_votes_fast's check
// and rescanned. −1 = no guess.
void Pipeline::guess_bpc_floors(int32_t cap, float* floor) {
  for (int j = 0; j < blob::kMaxJoints; ++j) floor[j] = -1.0f;
  const int trees = blob_.tree_count();
  const int joints = blob_.meta->joint_count;
  const int32_t step = evaluated_count_ / kFloorSamples > 1 ? evaluated_count_ / kFloorSamples : 1;
  const int32_t rank = (2 * cap + step - 1) / step;  // sampled pixels at or above the guess
  if (rank >= evaluated_count_ / step / 2) return;   // nearly everything is kept: no guess
  memset(guess_hist_, 0, sizeof(uint16_t) * blob::kMaxJoints * kGuessBuckets);
  const __m128 inv_total = _mm_set1_ps(1.0f / (32768.0f * float(trees)));
  const __m128i lowest = _mm_set1_epi32(kGuessLowestKey), highest = _mm_set1_epi32(kGuessLowestKey + kGuessBuckets - 1);
  int32_t taken = 0;
  for (int32_t i = 0; i < evaluated_count_ && taken < kMaxFloorSamples; i += step) {
    const EvaluatedPixel px = pixels_[i];
    if (skipped_by_user_filter(px)) continue;
    const int32_t ahead = i + kGuessPrefetchAhead * step;  // the rows are random reads beyond L1/L2
    if (ahead < evaluated_count_)
      for (int t = 0; t < trees; ++t)
        _mm_prefetch(reinterpret_cast<const char*>(joint_mass_ + size_t(leaf_of(ahead, t)) * blob::kMaxJoints), _MM_HINT_T0);
    __m128i acc[4] = {};
    for (int t = 0; t < trees; ++t) {
      const uint16_t* m = joint_mass_ + size_t(leaf_of(i, t)) * blob::kMaxJoints;
      const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(m));
      const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(m + 8));
      acc[0] = _mm_add_epi32(acc[0], _mm_cvtepu16_epi32(lo));
      acc[1] = _mm_add_epi32(acc[1], _mm_cvtepu16_epi32(_mm_srli_si128(lo, 8)));
      acc[2] = _mm_add_epi32(acc[2], _mm_cvtepu16_epi32(hi));
      acc[3] = _mm_add_epi32(acc[3], _mm_cvtepu16_epi32(_mm_srli_si128(hi, 8)));
    }
    const __m128 z = _mm_set1_ps(float(px.z_mm) * 0.001f);
    alignas(16) int32_t key[blob::kMaxJoints];
    for (int g = 0; g < 4; ++g) {
      const __m128 w = _mm_mul_ps(_mm_mul_ps(_mm_mul_ps(_mm_cvtepi32_ps(acc[g]), inv_total), z), z);
      const __m128i k = _mm_min_epi32(_mm_max_epi32(_mm_srli_epi32(_mm_castps_si128(w), 20), lowest), highest);
      _mm_store_si128(reinterpret_cast<__m128i*>(key + 4 * g), _mm_sub_epi32(k, lowest));
    }
    for (int j = 0; j < joints; ++j) ++guess_hist_[j * kGuessBuckets + key[j]];
    ++taken;
  }
  if (rank >= taken) return;
  for (int j = 0; j < joints; ++j) floor[j] = floor_at_rank(guess_hist_ + j * kGuessBuckets, rank, kGuessLowestKey);
}

// The OJR caster's floor guess: as guess_bpc_floors, over each sampled pixel's live votes (trees ×
// K per joint); a joint whose sampled votes are fewer than twice the rank gets no guess.
void Pipeline::guess_ojr_floors(int32_t cap, const uint32_t* lane_len2, float* floor) {
  for (int j = 0; j < blob::kMaxJoints; ++j) floor[j] = -1.0f;
  const int trees = blob_.tree_count();
  const int joints = blob_.meta->joint_count;
  const int k_votes = blob_.meta->votes_per_joint;
  const int32_t step = evaluated_count_ / kFloorSamples > 1 ? evaluated_count_ / kFloorSamples : 1;
  const int32_t rank = (2 * cap + step - 1) / step;  // sampled votes at or above the guess
  memset(guess_hist_, 0, sizeof(uint16_t) * blob::kMaxJoints * kGuessBuckets);
  int32_t sampled[blob::kMaxJoints] = {};
  int32_t taken = 0;
  for (int32_t i = 0; i < evaluated_count_ && taken < kMaxFloorSamples; i += step) {
    const EvaluatedPixel px = pixels_[i];
    if (skipped_by_user_filter(px)) continue;
    const int32_t ahead = i + kGuessPrefetchAhead * step;  // leaves are random reads beyond L1/L2
    if (ahead < evaluated_count_)
      for (int t = 0; t < trees; ++t) {
        const char* leaf = reinterpret_cast<const char*>(blob_.ojr_leaf(leaf_of(ahead, t)));
        for (size_t b = 0; b < size_t(joints * k_votes) * sizeof(blob::OjrVote); b += 64) _mm_prefetch(leaf + b, _MM_HINT_T0);
      }
    const float z = float(px.z_mm) * 0.001f;
    const float z2 = z * z;
    for (int t = 0; t < trees; ++t) {
      const blob::OjrVote* leaf = blob_.ojr_leaf(leaf_of(i, t));
      for (int l = 0; l < joints * k_votes; ++l) {
        const blob::OjrVote& ov = leaf[l];
        const uint32_t d2 = uint32_t(int32_t(ov.dx_mm) * ov.dx_mm) + uint32_t(int32_t(ov.dy_mm) * ov.dy_mm) +
                            uint32_t(int32_t(ov.dz_mm) * ov.dz_mm);
        if (ov.weight == 0 || d2 > lane_len2[l]) continue;
        const float w = float(ov.weight) * z2;
        uint32_t bits;
        memcpy(&bits, &w, sizeof bits);
        int32_t key = int32_t(bits >> 20) - kGuessLowestKeyOjr;
        key = key < 0 ? 0 : (key >= kGuessBuckets ? kGuessBuckets - 1 : key);
        const int j = l / k_votes;
        ++guess_hist_[j * kGuessBuckets + key];
        ++sampled[j];
      }
    }
    ++taken;
  }
  for (int j = 0; j < joints; ++j)  // fewer than twice the rank: nearly everything is kept, no guess
    if (sampled[j] >= 2 * rank) floor[j] = floor_at_rank(guess_hist_ + j * kGuessBuckets, rank, kGuessLowestKeyOjr);
}

void Pipeline::cast_bpc_votes_fast(const DepthFrame& f, FrameResult* r) {
  if (!joint_mass_) {  // huge forests keep no joint-mass table: the reference path is the only one
    cast_bpc_votes(f, r);
    return;
  }
  const blob::RuntimeConfig& cfg = *config_;
  const int joints = blob_.meta->joint_count;
  const int trees = blob_.tree_count();
  const int32_t cap = r->votes_per_joint_used;
  cast_cap_ = cap;
  alignas(64) float floor[blob::kMaxJoints];
  alignas(64) float push_back_m[blob::kMaxJoints] = {};
  alignas(64) uint32_t start_threshold[blob::kMaxJoints] = {};
  uint32_t candidates[blob::kMaxJoints] = {}, ignored[blob::kMaxJoints] = {};
  for (int j = 0; j < joints; ++j) {
    push_back_m[j] = float(cfg.joints[j].push_back_mm) * 0.001f;
    start_threshold[j] = uint32_t(cfg.joints[j].prob_threshold_q15) * uint32_t(trees);
  }
  guess_bpc_floors(cap, floor);
  kernels::BpcScanArgs a{pixels_, evaluated_count_, leaves_, max_pixels_, trees, joint_mass_,
                         1.0f / (32768.0f * float(trees)), f.intrinsics.cx, f.intrinsics.cy,
                         1.0f / f.intrinsics.fx, 1.0f / f.intrinsics.fy, push_back_m, start_threshold, floor,
                         user_filter_, user_filter_stride_, user_filter_id_, votes_, kVoteSlots, vote_counts_,
                         candidates, &Pipeline::on_buffer_full, this};
  const kernels::BpcScanFn scan = kernels::bpc_scan_kernel(kernel_);
  scan(a);
  // The guess was too high for a joint when fewer than min(cap, candidates) votes reached it: the
  // reference keeps some lighter vote. Such joints are scanned again without a floor (the others
  // with an unreachable one), which is always exact.
  bool again = false;
  for (int j = 0; j < joints; ++j) {
    const bool short_of_votes = uint32_t(vote_counts_[j]) < candidates[j] && vote_counts_[j] < cap;
    floor[j] = short_of_votes ? -1.0f : __builtin_inff();
    if (short_of_votes) vote_counts_[j] = 0;
    again = again || short_of_votes;
  }
  if (again) {
    a.candidates = ignored;
    scan(a);
  }
  bool dropped = false;
  for (int j = 0; j < joints; ++j) dropped = dropped || candidates[j] > uint32_t(cap);
  finish_votes(cap);
  if (dropped) r->flags |= kFlagVotesTruncated;
}

float Pipeline::on_buffer_full(void* ctx, int joint) {
  Pipeline* p = static_cast<Pipeline*>(ctx);
  return p->cut_votes(joint, p->cast_cap_);
}

void Pipeline::cast_ojr_votes_fast(const DepthFrame& f, FrameResult* r) {
  const blob::RuntimeConfig& cfg = *config_;
  const int joints = blob_.meta->joint_count;
  const int trees = blob_.tree_count();
  const int k_votes = blob_.meta->votes_per_joint;
  const int lanes = joints * k_votes;  // a leaf: votes in (joint, k) order, one lane each
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  const int32_t cap = r->votes_per_joint_used;
  constexpr int kMaxLanes = blob::kMaxJoints * blob::kMaxVotesPerLeafJoint;
  float floor_weight[blob::kMaxJoints];
  alignas(16) float lane_floor[kMaxLanes];
  alignas(16) int32_t lane_candidates[kMaxLanes] = {};  // live votes seen per lane (first scan)
  uint32_t lane_len2[kMaxLanes];
  // Squared vote length per lane as uint32 (|offset|² ≤ 3·2^30 and len² < 2^32 both fit), biased
  // by 2^31 so the signed compare of SSE orders them as unsigned; len 0 = no limit = 2^32 − 1.
  alignas(16) uint32_t lane_len2_biased[kMaxLanes];
  uint8_t lane_joint[kMaxLanes];
  for (int l = 0; l < lanes; ++l) {
    const int j = l / k_votes;
    const uint32_t len = cfg.joints[j].vote_length_mm;
    lane_len2[l] = len == 0 ? 0xFFFFFFFFu : len * len;
    lane_len2_biased[l] = lane_len2[l] ^ 0x80000000u;
    lane_joint[l] = uint8_t(j);
  }
  // Each joint's floor starts at a guess (guess_ojr_floors); a guess above the reference's top-Nsub
  // is caught after the scan and that joint is scanned again without one, as in the BPC caster.
  guess_ojr_floors(cap, lane_len2, floor_weight);
  for (int l = 0; l < lanes; ++l) lane_floor[l] = floor_weight[lane_joint[l]];
  const int full = lanes & ~3;
  const __m128i xyz_only = _mm_setr_epi16(-1, -1, -1, 0, -1, -1, -1, 0);
  const __m128i bias = _mm_set1_epi32(int32_t(0x80000000u));
  const __m128i zero = _mm_setzero_si128();
  const __m128i all_ones = _mm_set1_epi32(-1);

  auto push = [&](int32_t i, int t, int l, float x, float y, float z, float weight, const blob::OjrVote& ov) {
    const int j = lane_joint[l], k = l - j * k_votes;
    const uint32_t order = (uint32_t(i) * uint32_t(trees) + uint32_t(t)) * uint32_t(k_votes) + uint32_t(k);
    Vote v{x + float(ov.dx_mm) * 0.001f, y + float(ov.dy_mm) * 0.001f, z + float(ov.dz_mm) * 0.001f, weight, order, 1};
    const float before = floor_weight[j];
    append_vote(j, cap, v, &floor_weight[j]);
    if (floor_weight[j] != before)
      for (int q = j * k_votes; q < (j + 1) * k_votes; ++q) lane_floor[q] = floor_weight[j];
  };

  auto scan = [&](bool count_candidates) {
    for (int32_t i = 0; i < evaluated_count_; ++i) {
      const EvaluatedPixel px = pixels_[i];
      if (skipped_by_user_filter(px)) continue;
      const float z = float(px.z_mm) * 0.001f;
      const float z2 = z * z;
      const float x = (float(px.u) - f.intrinsics.cx) * z * inv_fx;
      const float y = -(float(px.v) - f.intrinsics.cy) * z * inv_fy;
      const __m128 z2_4 = _mm_set1_ps(z2);
      if (i + kVotePrefetchAhead < evaluated_count_)
        for (int t = 0; t < trees; ++t) {
          const char* ahead = reinterpret_cast<const char*>(blob_.ojr_leaf(leaf_of(i + kVotePrefetchAhead, t)));
          for (size_t b = 0; b < size_t(lanes) * sizeof(blob::OjrVote); b += 64) _mm_prefetch(ahead + b, _MM_HINT_T0);
        }
      for (int t = 0; t < trees; ++t) {
        const blob::OjrVote* leaf = blob_.ojr_leaf(leaf_of(i, t));
        int l = 0;
        for (; l < full; l += 4) {
          const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(leaf + l));
          const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(leaf + l + 2));
          const __m128i xa = _mm_and_si128(a, xyz_only), xb = _mm_and_si128(b, xyz_only);
          // dx²+dy², dz² per vote (pmaddwd; its only wrap, 2·(−32768)², is 2^31 read as unsigned),
          // then summed modulo 2^32 — exact, as the true sum is below 2^32.
          const __m128i d2 = _mm_hadd_epi32(_mm_madd_epi16(xa, xa), _mm_madd_epi16(xb, xb));
          const __m128i too_long = _mm_cmpgt_epi32(_mm_xor_si128(d2, bias),
                                                   _mm_load_si128(reinterpret_cast<const __m128i*>(lane_len2_biased + l)));
          const __m128i wa = _mm_srli_epi64(a, 48), wb = _mm_srli_epi64(b, 48);  // weights in dwords 0, 2
          const __m128i wq = _mm_castps_si128(
              _mm_shuffle_ps(_mm_castsi128_ps(wa), _mm_castsi128_ps(wb), _MM_SHUFFLE(2, 0, 2, 0)));
          const __m128i dead = _mm_or_si128(too_long, _mm_cmpeq_epi32(wq, zero));
          const __m128 w = _mm_mul_ps(_mm_cvtepi32_ps(wq), z2_4);
          const __m128 below = _mm_cmplt_ps(w, _mm_load_ps(lane_floor + l));
          const int dead_bits = _mm_movemask_ps(_mm_castsi128_ps(dead)), below_bits = _mm_movemask_ps(below);
          if (count_candidates) {
            __m128i* counts = reinterpret_cast<__m128i*>(lane_candidates + l);
            _mm_store_si128(counts, _mm_sub_epi32(_mm_load_si128(counts), _mm_andnot_si128(dead, all_ones)));
          }
          int keep = ~(below_bits | dead_bits) & 15;
          if (!keep) continue;
          alignas(16) float wl[4];
          _mm_store_ps(wl, w);
          for (; keep; keep &= keep - 1) {
            const int lane = l + __builtin_ctz(unsigned(keep));
            push(i, t, lane, x, y, z, wl[lane - l], leaf[lane]);
          }
        }
        for (; l < lanes; ++l) {  // the reference's scalar test for the last lanes
          const blob::OjrVote& ov = leaf[l];
          if (ov.weight == 0) continue;
          const int64_t d2 = int64_t(ov.dx_mm) * ov.dx_mm + int64_t(ov.dy_mm) * ov.dy_mm + int64_t(ov.dz_mm) * ov.dz_mm;
          const int64_t len = cfg.joints[lane_joint[l]].vote_length_mm;
          if (len != 0 && d2 > len * len) continue;
          if (count_candidates) ++lane_candidates[l];
          const float weight = float(ov.weight) * z2;
          if (weight < lane_floor[l]) continue;
          push(i, t, l, x, y, z, weight, ov);
        }
      }
    }
  };
  scan(true);
  int32_t candidates[blob::kMaxJoints] = {};
  for (int l = 0; l < lanes; ++l) candidates[lane_joint[l]] += lane_candidates[l];
  bool again = false;
  for (int j = 0; j < joints; ++j) {
    // Fewer than min(cap, candidates) kept: the guess was above the reference's top-Nsub.
    const bool short_of_votes = vote_counts_[j] < candidates[j] && vote_counts_[j] < cap;
    floor_weight[j] = short_of_votes ? -1.0f : __builtin_inff();
    if (short_of_votes) vote_counts_[j] = 0;
    again = again || short_of_votes;
  }
  if (again) {
    for (int l = 0; l < lanes; ++l) lane_floor[l] = floor_weight[lane_joint[l]];
    scan(false);
  }
  bool dropped = false;
  for (int j = 0; j < joints; ++j) dropped = dropped || candidates[j] > cap;
  finish_votes(cap);
  if (dropped) r->flags |= kFlagVotesTruncated;
}

void Pipeline::aggregate(FrameResult* r) {
  const blob::RuntimeConfig& cfg = *config_;
  const int joints = blob_.meta->joint_count;
  float* const sx_row = soa_;
  float* const sy_row = soa_ + kSoaRow;
  float* const sz_row = soa_ + 2 * kSoaRow;
  float* const sw_row = soa_ + 3 * kSoaRow;
  // The sums' definition (lanes, reduction order) is the same for every ISA: mean_shift_kernel.h.
  const kernels::MeanShiftSumsFn sums = kernels::mean_shift_sums_kernel(kernel_);
  for (int j = 0; j < joints; ++j) {
    Vote* votes = votes_ + size_t(j) * kVoteSlots;
    const int32_t nv = vote_counts_[j];
    if (nv == 0) continue;
    // Canonical order (casting order, unique) so results do not depend on heap internals. The fast
    // casters keep their votes in casting order already; the reference's heap does not.
    auto by_order = [](const Vote& a, const Vote& b) { return a.order < b.order; };
    if (!std::is_sorted(votes, votes + nv, by_order)) std::sort(votes, votes + nv, by_order);
    // Starting points: eligible votes, evenly strided down to the cap.
    int32_t eligible = 0;
    for (int32_t i = 0; i < nv; ++i) eligible += votes[i].start ? 1 : 0;
    if (eligible == 0) continue;
    const int32_t cap = r->starts_per_joint_used;
    const int32_t step = (eligible + cap - 1) / cap;
    if (step > 1) r->flags |= kFlagStartsTruncated;
    int32_t ns = 0, e = 0;
    for (int32_t i = 0; i < nv && ns < cap; ++i)
      if (votes[i].start && (e++ % step) == 0) starts_[ns++] = votes[i];
    // Votes as structure of arrays, padded to a multiple of 16 lanes with weightless votes.
    const int32_t padded = (nv + kernels::kMeanShiftLanes - 1) & ~(kernels::kMeanShiftLanes - 1);
    for (int32_t i = 0; i < padded; ++i) {
      const bool real = i < nv;
      sx_row[i] = real ? votes[i].x : 0.0f;
      sy_row[i] = real ? votes[i].y : 0.0f;
      sz_row[i] = real ? votes[i].z : 0.0f;
      sw_row[i] = real ? votes[i].weight : 0.0f;
    }

    const float b = float(cfg.joints[j].bandwidth_mm) * 0.001f;
    const float inv_b2 = 1.0f / (b * b);
    const float tol = float(cfg.merge_tolerance_mm) * 0.001f;
    const float tol2 = tol * tol;
    const float stop2 = 1e-6f;  // (1 mm)²
    int32_t nm = 0;             // modes: x, y, z, confidence
    for (int32_t s = 0; s < ns; ++s) {
      float mx = starts_[s].x, my = starts_[s].y, mz = starts_[s].z;
      for (int it = 0; it < r->iterations_used; ++it) {
        float sum[4];
        sums(sx_row, sy_row, sz_row, sw_row, padded, mx, my, mz, inv_b2, sum);
        const float sw = sum[0];
        if (!(sw > 0.0f)) break;
        const float nx = sum[1] / sw, ny = sum[2] / sw, nz = sum[3] / sw;
        const float d2 = (nx - mx) * (nx - mx) + (ny - my) * (ny - my) + (nz - mz) * (nz - mz);
        mx = nx; my = ny; mz = nz;
        if (d2 < stop2) break;
        // A path that reaches a known mode ends there (same basin): saves most iterations.
        bool joined = false;
        for (int32_t m = 0; m < nm && !joined; ++m) {
          const float* q = modes_ + 4 * m;
          joined = (q[0] - mx) * (q[0] - mx) + (q[1] - my) * (q[1] - my) + (q[2] - mz) * (q[2] - mz) < 0.25f * tol2;
        }
        if (joined) break;
      }
      int32_t m = 0;
      for (; m < nm; ++m) {
        const float* q = modes_ + 4 * m;
        if ((q[0] - mx) * (q[0] - mx) + (q[1] - my) * (q[1] - my) + (q[2] - mz) * (q[2] - mz) < tol2) break;
      }
      if (m == nm) {
        float* q = modes_ + 4 * nm++;
        q[0] = mx; q[1] = my; q[2] = mz; q[3] = 0.0f;
      }
    }
    // Confidence: every vote adds its weight to the nearest mode within 3 bandwidths.
    const float reach2 = 9.0f * b * b;
    // Four votes at a time: each lane keeps the first mode with the smallest (dx·dx + dy·dy) + dz·dz
    // below reach2 (strict <, modes in order), then the weights are added in vote order.
    const __m128 reach4 = _mm_set1_ps(reach2);
    for (int32_t i = 0; i < nv; i += 4) {
      const __m128 x = _mm_loadu_ps(sx_row + i), y = _mm_loadu_ps(sy_row + i), z = _mm_loadu_ps(sz_row + i);
      __m128 best_d2 = reach4;
      __m128i best = _mm_set1_epi32(-1);
      for (int32_t m = 0; m < nm; ++m) {
        const float* q = modes_ + 4 * m;
        const __m128 dx = _mm_sub_ps(x, _mm_set1_ps(q[0])), dy = _mm_sub_ps(y, _mm_set1_ps(q[1])),
                     dz = _mm_sub_ps(z, _mm_set1_ps(q[2]));
        const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
        const __m128 closer = _mm_cmplt_ps(d2, best_d2);
        best_d2 = _mm_blendv_ps(best_d2, d2, closer);
        best = _mm_castps_si128(_mm_blendv_ps(_mm_castsi128_ps(best), _mm_castsi128_ps(_mm_set1_epi32(m)), closer));
      }
      alignas(16) int32_t lane_best[4];
      _mm_store_si128(reinterpret_cast<__m128i*>(lane_best), best);
      for (int32_t l = 0; l < 4 && i + l < nv; ++l)
        if (lane_best[l] >= 0) modes_[4 * lane_best[l] + 3] += sw_row[i + l];
    }
    // Top proposals by confidence (selection: nm ≤ kMaxStartsCap, output ≤ kMaxProposals).
    const int32_t out_cap = cfg.max_proposals_per_joint;
    int32_t out = 0;
    int32_t nonzero = 0;
    for (int32_t m = 0; m < nm; ++m) nonzero += modes_[4 * m + 3] > 0.0f;
    if (nonzero > out_cap) r->flags |= kFlagProposalsTruncated;
    while (out < out_cap) {
      int32_t best = -1;
      for (int32_t m = 0; m < nm; ++m)
        if (modes_[4 * m + 3] > 0.0f && (best < 0 || modes_[4 * m + 3] > modes_[4 * best + 3])) best = m;
      if (best < 0) break;
      r->proposals[j][out++] = JointProposal{modes_[4 * best], modes_[4 * best + 1], modes_[4 * best + 2], modes_[4 * best + 3]};
      modes_[4 * best + 3] = -1.0f;
    }
    r->proposal_count[j] = out;
  }
}

}  // namespace dp
