#include <string.h>
#include <x86intrin.h>

#include "runtime/arena.h"
#include "runtime/depthpose.h"
#include "runtime/fast_math.h"
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp {

struct Vote {
  float x, y, z;   // metres
  float weight;    // p·z² (BPC) or w·z² (OJR)
  uint32_t order;  // casting order (canonical order for aggregation)
  uint32_t start;  // 1 when this vote may seed mean shift (BPC: p > λc)
};

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
    case Status::kArenaTooSmall: return "arena smaller than required_arena_bytes()";
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

// Everything init carves, in one place so required_arena_bytes and init agree.
struct Layout {
  uint16_t* probe_image;
  EvaluatedPixel* pixels;
  uint32_t* leaves;
  Vote* votes;
  int32_t* vote_counts;
  Vote* starts;
  float* modes;
  blob::RuntimeConfig* config;
  kernels::PackedNode* packed_nodes;  // nullptr when the forest's offsets do not fit the packing
};

// Measured in docs/runtime_speed.md: the packed 8-byte nodes cost more decode work than they save in
// cache misses with the current kernels, so the pipeline evaluates the blob's nodes in place.
constexpr bool kUsePackedNodes = false;
bool packable(const blob::LoadedBlob& b) {
  return kUsePackedNodes && int32_t(b.meta->max_abs_offset_pxm) <= kernels::kPackedMaxOffset;
}

bool carve(ArenaCarver& c, const blob::LoadedBlob& b, int32_t w, int32_t h, int32_t max_pixels, Layout* l) {
  l->config = c.tail<blob::RuntimeConfig>(1);
  l->packed_nodes = packable(b) ? c.tail<kernels::PackedNode>(size_t(b.tree_count()) * blob::nodes_per_tree(b.depth()))
                                : nullptr;
  l->probe_image = c.head<uint16_t>(kernels::padded_probe_elements(w, h));
  l->pixels = c.head<EvaluatedPixel>(size_t(max_pixels));
  l->leaves = c.head<uint32_t>(size_t(max_pixels) * size_t(b.tree_count()));
  l->votes = c.head<Vote>(size_t(blob::kMaxJoints) * blob::kMaxVotesCap);
  l->vote_counts = c.head<int32_t>(blob::kMaxJoints);
  l->starts = c.head<Vote>(blob::kMaxStartsCap);
  l->modes = c.head<float>(size_t(blob::kMaxStartsCap) * 4);
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

size_t required_arena_bytes(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height) {
  if (!blob.meta || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return 0;
  ArenaCarver counter(nullptr, size_t(-1) / 2);
  Layout l;
  carve(counter, blob, max_width, max_height, max_pixels_for(blob, max_width, max_height), &l);
  return counter.used();
}

Status Pipeline::init(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height, uint8_t* arena,
                      size_t arena_bytes) {
  initialized_ = false;
  if (!blob.meta || !arena || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return Status::kBadArgument;
  if (reinterpret_cast<uintptr_t>(arena) % kArenaAlignment != 0) return Status::kArenaMisaligned;
  if (arena_bytes < required_arena_bytes(blob, max_width, max_height)) return Status::kArenaTooSmall;
  ArenaCarver c(arena, arena_bytes);
  Layout l;
  const int32_t max_pixels = max_pixels_for(blob, max_width, max_height);
  if (!carve(c, blob, max_width, max_height, max_pixels, &l)) return Status::kArenaTooSmall;
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
  packed_nodes_ = l.packed_nodes;
  if (packed_nodes_) {
    const size_t count = size_t(blob.tree_count()) * blob::nodes_per_tree(blob.depth());
    for (size_t i = 0; i < count; ++i) packed_nodes_[i] = kernels::pack_node(blob.nodes[i]);
  }
  evaluated_count_ = 0;
  kernel_ = KernelIsa::kScalar;
  initialized_ = true;
  set_kernel(KernelIsa::kBest);
  return Status::kOk;
}

Status Pipeline::set_kernel(KernelIsa isa) {
  if (!kernel_isa_supported(isa)) return Status::kKernelUnavailable;
  if (isa == KernelIsa::kBest) {
    isa = kernel_isa_supported(KernelIsa::kAvx512) ? KernelIsa::kAvx512
          : kernel_isa_supported(KernelIsa::kAvx2) ? KernelIsa::kAvx2
                                                     : KernelIsa::kScalar;
  }
  kernel_ = isa;
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
  return Status::kOk;
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
  int32_t fg = 0;
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const uint8_t* mrow = f.foreground_mask ? f.foreground_mask + size_t(v) * f.stride_px : nullptr;
    uint16_t* out = probe_image_ + size_t(v + 1) * probe_stride + 1;
    for (int32_t u = 0; u < w; ++u) {
      const uint16_t z = row[u];
      const bool is_fg = z != 0 && z < kBackgroundDepthMm &&
                         (mrow ? mrow[u] != 0 : (z >= cfg.near_mm && z <= cfg.far_mm));
      out[u] = is_fg ? z : kBackgroundDepthMm;
      fg += is_fg;
    }
  }
  r->foreground_pixels = fg;
  const int32_t budget = int32_t(cfg.max_evaluated_pixels) < max_pixels_ ? int32_t(cfg.max_evaluated_pixels) : max_pixels_;
  int32_t stride = 1;
  if (fg > budget) {
    stride = (fg + budget - 1) / budget;
    r->flags |= kFlagPixelsStrided;
  }
  r->pixel_stride = stride;
  int32_t n = 0, seen = 0;
  for (int32_t v = 0; v < h && n < budget; ++v) {
    const uint16_t* row = probe_image_ + size_t(v + 1) * probe_stride + 1;
    for (int32_t u = 0; u < w; ++u) {
      if (row[u] == kBackgroundDepthMm) continue;
      if (seen++ % stride != 0) continue;
      if (n >= budget) break;
      pixels_[n++] = EvaluatedPixel{uint16_t(u), uint16_t(v), row[u], 0};
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
  const kernels::ForestKernelFn kernel = kernels::forest_kernel(kernel_);
  for (int t = 0; t < blob_.tree_count(); ++t) {
    const kernels::PackedNode* packed =
        packed_nodes_ ? packed_nodes_ + size_t(t) * blob::nodes_per_tree(blob_.depth()) : nullptr;
    kernels::ForestKernelArgs a{probe_image_, probe_stride, w, h, focal, pixels_, n, blob_.tree_nodes(t), packed,
                                blob_.tree_leaf_index(t), blob_.depth(), leaves_ + size_t(t) * max_pixels_};
    kernel(a);
  }
  const uint64_t t2 = cycles_now();
  r->stage_cycles[kStageForest] = t2 - t1;

  // Stage 3: votes.
  for (int j = 0; j < blob::kMaxJoints; ++j) vote_counts_[j] = 0;
  if (blob_.method() == blob::Method::kBpc)
    cast_bpc_votes(f, r);
  else
    cast_ojr_votes(f, r);
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
  for (int j = 0; j < blob::kMaxJoints; ++j) vote_counts_[j] = 0;
  if (blob_.method() == blob::Method::kBpc)
    cast_bpc_votes(f, r);
  else
    cast_ojr_votes(f, r);
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
  const DepthFrame f{nullptr, 0, 0, 0, intr, nullptr};  // the vote casters read only the intrinsics
  for (int j = 0; j < blob::kMaxJoints; ++j) vote_counts_[j] = 0;
  if (blob_.method() == blob::Method::kBpc)
    cast_bpc_votes(f, r);
  else
    cast_ojr_votes(f, r);
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
  const int32_t cap = cfg.max_votes_per_joint;
  for (int32_t i = 0; i < evaluated_count_; ++i) {
    const EvaluatedPixel px = pixels_[i];
    if (skipped_by_user_filter(px)) continue;
    uint32_t acc[blob::kMaxParts] = {};
    for (int t = 0; t < trees; ++t) {
      const uint16_t* p = blob_.bpc_leaf(leaf_of(i, t));
      for (int c = 0; c < parts; ++c) acc[c] += p[c];
    }
    const float z = float(px.z_mm) * 0.001f;
    const float x = (float(px.u) - f.intrinsics.cx) * z * inv_fx;
    const float y = -(float(px.v) - f.intrinsics.cy) * z * inv_fy;
    for (int j = 0; j < joints; ++j) {
      const blob::JointConfig& jc = cfg.joints[j];
      uint32_t mass = 0;
      for (uint32_t m = jc.part_mask; m; m &= m - 1) mass += acc[__builtin_ctz(m)];
      if (mass == 0) continue;
      const float p = float(mass) * inv_total;
      Vote v{x, y, z + float(jc.push_back_mm) * 0.001f, p * z * z, uint32_t(i),
             uint32_t(mass * 32768ull > uint64_t(jc.prob_threshold_q15) * 32768ull * uint64_t(trees) ? 1 : 0)};
      if (push_top_n(votes_ + size_t(j) * blob::kMaxVotesCap, &vote_counts_[j], cap, v)) r->flags |= kFlagVotesTruncated;
    }
  }
}

void Pipeline::cast_ojr_votes(const DepthFrame& f, FrameResult* r) {
  const blob::RuntimeConfig& cfg = *config_;
  const int joints = blob_.meta->joint_count;
  const int trees = blob_.tree_count();
  const int k_votes = blob_.meta->votes_per_joint;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  const int32_t cap = cfg.max_votes_per_joint;
  for (int32_t i = 0; i < evaluated_count_; ++i) {
    const EvaluatedPixel px = pixels_[i];
    if (skipped_by_user_filter(px)) continue;
    const float z = float(px.z_mm) * 0.001f;
    const float x = (float(px.u) - f.intrinsics.cx) * z * inv_fx;
    const float y = -(float(px.v) - f.intrinsics.cy) * z * inv_fy;
    for (int t = 0; t < trees; ++t) {
      const blob::OjrVote* leaf = blob_.ojr_leaf(leaf_of(i, t));
      for (int j = 0; j < joints; ++j) {
        const int32_t len = cfg.joints[j].vote_length_mm;
        const int64_t len2 = int64_t(len) * len;
        for (int k = 0; k < k_votes; ++k) {
          const blob::OjrVote& ov = leaf[j * k_votes + k];
          if (ov.weight == 0) continue;
          const int64_t d2 = int64_t(ov.dx_mm) * ov.dx_mm + int64_t(ov.dy_mm) * ov.dy_mm + int64_t(ov.dz_mm) * ov.dz_mm;
          if (len != 0 && d2 > len2) continue;
          // The order depends on (pixel, tree, k) only, never on other joints' vote-length filters:
          // each joint's proposals depend only on its own JointConfig (tune relies on this).
          const uint32_t order = (uint32_t(i) * uint32_t(trees) + uint32_t(t)) * uint32_t(k_votes) + uint32_t(k);
          Vote v{x + float(ov.dx_mm) * 0.001f, y + float(ov.dy_mm) * 0.001f, z + float(ov.dz_mm) * 0.001f,
                 float(ov.weight) * z * z, order, 1};
          if (push_top_n(votes_ + size_t(j) * blob::kMaxVotesCap, &vote_counts_[j], cap, v))
            r->flags |= kFlagVotesTruncated;
        }
      }
    }
  }
}

void Pipeline::aggregate(FrameResult* r) {
  const blob::RuntimeConfig& cfg = *config_;
  const int joints = blob_.meta->joint_count;
  for (int j = 0; j < joints; ++j) {
    Vote* votes = votes_ + size_t(j) * blob::kMaxVotesCap;
    const int32_t nv = vote_counts_[j];
    if (nv == 0) continue;
    // Canonical order (casting order) so results do not depend on heap internals.
    for (int32_t a = 1; a < nv; ++a) {  // insertion sort: nv ≤ kMaxVotesCap, mostly short
      Vote key = votes[a];
      int32_t b = a - 1;
      while (b >= 0 && votes[b].order > key.order) { votes[b + 1] = votes[b]; --b; }
      votes[b + 1] = key;
    }
    // Starting points: eligible votes, evenly strided down to the cap.
    int32_t eligible = 0;
    for (int32_t i = 0; i < nv; ++i) eligible += votes[i].start ? 1 : 0;
    if (eligible == 0) continue;
    const int32_t cap = cfg.max_starts_per_joint;
    const int32_t step = (eligible + cap - 1) / cap;
    if (step > 1) r->flags |= kFlagStartsTruncated;
    int32_t ns = 0, e = 0;
    for (int32_t i = 0; i < nv && ns < cap; ++i)
      if (votes[i].start && (e++ % step) == 0) starts_[ns++] = votes[i];

    const float b = float(cfg.joints[j].bandwidth_mm) * 0.001f;
    const float inv_b2 = 1.0f / (b * b);
    const float tol = float(cfg.merge_tolerance_mm) * 0.001f;
    const float tol2 = tol * tol;
    const float stop2 = 1e-6f;  // (1 mm)²
    int32_t nm = 0;             // modes: x, y, z, confidence
    for (int32_t s = 0; s < ns; ++s) {
      float mx = starts_[s].x, my = starts_[s].y, mz = starts_[s].z;
      for (int it = 0; it < cfg.mean_shift_iterations; ++it) {
        float sw = 0, sx = 0, sy = 0, sz = 0;
        for (int32_t i = 0; i < nv; ++i) {
          const float dx = votes[i].x - mx, dy = votes[i].y - my, dz = votes[i].z - mz;
          const float k = votes[i].weight * exp_neg((dx * dx + dy * dy + dz * dz) * inv_b2);
          sw += k; sx += k * votes[i].x; sy += k * votes[i].y; sz += k * votes[i].z;
        }
        if (!(sw > 0.0f)) break;
        const float nx = sx / sw, ny = sy / sw, nz = sz / sw;
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
    for (int32_t i = 0; i < nv; ++i) {
      int32_t best = -1;
      float best_d2 = reach2;
      for (int32_t m = 0; m < nm; ++m) {
        const float* q = modes_ + 4 * m;
        const float dx = votes[i].x - q[0], dy = votes[i].y - q[1], dz = votes[i].z - q[2];
        const float d2 = dx * dx + dy * dy + dz * dz;
        if (d2 < best_d2) { best_d2 = d2; best = m; }
      }
      if (best >= 0) modes_[4 * best + 3] += votes[i].weight;
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
