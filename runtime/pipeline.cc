// The pipeline orchestrates the stages (depthpose.h lists them; docs/architecture.md maps each to
// its file): it carves the arena at init, checks every argument at the API edge, then hands each
// stage its inputs and times it. No stage body and no instruction-set code lives here.
#include <string.h>

#include "runtime/arena.h"
#include "runtime/bpc_votes.h"
#include "runtime/budget_plan.h"
#include "runtime/cycle_counter.h"
#include "runtime/debug_check.h"
#include "runtime/depthpose.h"
#include "runtime/foreground.h"
#include "runtime/forest.h"
#include "runtime/kernels/dispatch.h"
#include "runtime/mean_shift.h"
#include "runtime/ojr_votes.h"
#include "runtime/vote_selection.h"
#include "runtime/votes.h"

namespace dp {

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
  static const char* const names[kStageCount] = {"foreground", "forest", "votes", "mean_shift", "skeleton"};
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
  float* soa;
  uint64_t* cell_keys;
  int32_t* cell_ids;
  uint32_t* select_keys;
  uint16_t* guess_hist;
  blob::RuntimeConfig* config;
  kernels::SplitNode* split_nodes;
  uint32_t* leaf_index;
  uint16_t* joint_mass;
  uint32_t* ojr_live_offsets;
  blob::OjrVote* ojr_live_votes;
  uint8_t* ojr_live_lanes;
};

// The kernels read split nodes (kernels::SplitNode: offsets, left child and threshold in one
// 16-byte node, one cache line per visit; the fewest ops per visit of the layouts measured,
// docs/runtime_speed.md) and a leaf-record index per node, both derived at init from the blob's split
// flags and split nodes (blob_format.h: the blob stores neither child nor record indices nor leaf
// nodes): 20 bytes per node, 10 per split node and 10 per leaf node. The OJR live-vote copy
// (ojr_votes.h) is the optional copy: without it (a minimum arena) the fast caster scans the blob's
// votes.
bool carve(ArenaCarver& c, const blob::LoadedBlob& b, int32_t w, int32_t h, int32_t max_pixels, bool optional,
           Layout* l) {
  l->config = c.tail<blob::RuntimeConfig>(1);
  const size_t nodes = b.total_nodes;
  l->split_nodes = c.tail<kernels::SplitNode>(nodes);
  l->leaf_index = c.tail<uint32_t>(nodes);
  l->joint_mass = use_joint_mass(b) ? c.tail<uint16_t>(size_t(b.meta->leaf_count) * blob::kMaxJoints) : nullptr;
  const bool live = optional && use_ojr_live_votes(b);
  l->ojr_live_offsets = live ? c.tail<uint32_t>(size_t(b.meta->leaf_count) + 1) : nullptr;
  l->ojr_live_votes = live ? c.tail<blob::OjrVote>(b.meta->entry_count) : nullptr;
  l->ojr_live_lanes = live ? c.tail<uint8_t>(b.meta->entry_count) : nullptr;
  l->probe_image = c.head<uint16_t>(kernels::padded_probe_elements(w, h));
  l->pixels = c.head<EvaluatedPixel>(size_t(max_pixels));
  l->leaves = c.head<uint32_t>(size_t(max_pixels) * size_t(b.tree_count()));
  l->votes = c.head<Vote>(size_t(blob::kMaxJoints) * kVoteSlots);
  l->vote_counts = c.head<int32_t>(blob::kMaxJoints);
  l->starts = c.head<Vote>(blob::kMaxStartsCap);
  l->modes = c.head<float>(size_t(blob::kMaxStartsCap) * 4);
  l->soa = c.head<float>(size_t(kSoaRow) * 4);
  l->cell_keys = c.head<uint64_t>(kCellSlots);
  l->cell_ids = c.head<int32_t>(kCellSlots);
  l->select_keys = c.head<uint32_t>(size_t(2 * kVoteSlots));
  l->guess_hist = c.head<uint16_t>(size_t(blob::kMaxJoints) * kGuessBuckets);
  return c.ok();
}

int32_t max_pixels_for(const blob::LoadedBlob& b, int32_t w, int32_t h) {
  const int64_t frame = int64_t(w) * h;
  const int64_t budget = b.config->max_evaluated_pixels;
  return int32_t(frame < budget ? frame : budget);
}

size_t arena_bytes_for(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height, bool optional) {
  if (!blob.meta || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return 0;
  ArenaCarver counter(nullptr, size_t(-1) / 2);
  Layout l;
  carve(counter, blob, max_width, max_height, max_pixels_for(blob, max_width, max_height), optional, &l);
  return counter.used();
}

// Intrinsics every stage can use: finite, positive focal lengths (a focal length of +inf would
// make every probe offset saturate and every 3D point 0; NaN would reach integer conversions).
bool usable(const CameraIntrinsics& c) {
  return __builtin_isfinite(c.fx) && __builtin_isfinite(c.fy) && __builtin_isfinite(c.cx) &&
         __builtin_isfinite(c.cy) && c.fx > 0.0f && c.fy > 0.0f;
}

}  // namespace

size_t required_arena_bytes(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height) {
  return arena_bytes_for(blob, max_width, max_height, true);
}
size_t minimum_arena_bytes(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height) {
  return arena_bytes_for(blob, max_width, max_height, false);
}

Pipeline::Pipeline(Pipeline&& other) noexcept : s_(other.s_) { other.s_ = State{}; }

Pipeline& Pipeline::operator=(Pipeline&& other) noexcept {
  if (this != &other) {
    s_ = other.s_;
    other.s_ = State{};
  }
  return *this;
}

Status Pipeline::init(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height, uint8_t* arena,
                      size_t arena_bytes) {
  s_.initialized = false;
  if (!blob.meta || !arena || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return Status::kBadArgument;
  if (reinterpret_cast<uintptr_t>(arena) % kArenaAlignment != 0) return Status::kArenaMisaligned;
  if (arena_bytes < minimum_arena_bytes(blob, max_width, max_height)) return Status::kArenaTooSmall;
  const bool optional = arena_bytes >= required_arena_bytes(blob, max_width, max_height);
  ArenaCarver c(arena, arena_bytes);
  Layout l;
  const int32_t max_pixels = max_pixels_for(blob, max_width, max_height);
  if (!carve(c, blob, max_width, max_height, max_pixels, optional, &l)) return Status::kArenaTooSmall;
  State s;
  s.blob = blob;
  s.max_width = max_width;
  s.max_height = max_height;
  s.max_pixels = max_pixels;
  s.arena = arena;
  s.arena_bytes = arena_bytes;
  s.arena_used = c.used();
  s.probe_image = l.probe_image;
  s.pixels = l.pixels;
  s.leaves = l.leaves;
  s.votes = l.votes;
  s.vote_counts = l.vote_counts;
  s.select_keys = l.select_keys;
  s.guess_hist = l.guess_hist;
  s.starts = l.starts;
  s.modes = l.modes;
  s.soa = l.soa;
  s.cell_keys = l.cell_keys;
  s.cell_ids = l.cell_ids;
  s.config = l.config;
  *s.config = *blob.config;
  s.split_nodes = l.split_nodes;
  s.leaf_index = l.leaf_index;
  s.joint_mass = l.joint_mass;
  if (s.joint_mass) build_joint_mass(blob, *s.config, s.joint_mass);
  s.ojr_live_offsets = l.ojr_live_offsets;
  s.ojr_live_votes = l.ojr_live_votes;
  s.ojr_live_lanes = l.ojr_live_lanes;
  if (s.ojr_live_offsets) build_ojr_live_votes(blob, *s.config, s.ojr_live_offsets, s.ojr_live_votes, s.ojr_live_lanes);
  build_forest_tables(blob, s.split_nodes, s.leaf_index);
  s.initialized = true;
  s_ = s;
  set_kernel(KernelIsa::kBest);
  return Status::kOk;
}

Status Pipeline::set_kernel(KernelIsa isa) {
  if (!kernel_isa_supported(isa)) return Status::kKernelUnavailable;
  if (isa == KernelIsa::kBest) {
    s_.kernel = widest_kernel_isa();
    s_.forest_kernel = best_forest_kernel_isa();
  } else {
    s_.kernel = s_.forest_kernel = isa;
  }
  return Status::kOk;
}

Status Pipeline::set_config(const blob::RuntimeConfig& config) {
  if (!s_.initialized) return Status::kNotInitialized;
  if (blob::validate_config(*s_.blob.meta, config) != blob::BlobStatus::kOk) return Status::kBadConfig;
  // The arena was sized for the blob's pixel budget; a larger one would overrun it.
  if (int64_t(config.max_evaluated_pixels) > int64_t(s_.max_pixels) &&
      int64_t(s_.max_pixels) < int64_t(s_.max_width) * s_.max_height)
    return Status::kBadConfig;
  *s_.config = config;
  if (s_.joint_mass) build_joint_mass(s_.blob, config, s_.joint_mass);
  if (s_.ojr_live_offsets)
    build_ojr_live_votes(s_.blob, config, s_.ojr_live_offsets, s_.ojr_live_votes, s_.ojr_live_lanes);
  return Status::kOk;
}

void Pipeline::part_distribution(int32_t i, uint16_t* out) const {
  DP_DCHECK(s_.initialized && i >= 0 && i < s_.evaluated_count);
  const int parts = s_.blob.meta->part_count;
  const int trees = s_.blob.tree_count();
  uint32_t acc[blob::kMaxParts] = {};
  for (int t = 0; t < trees; ++t) blob::add_bpc_leaf(s_.blob, leaf_of(i, t), acc);
  for (int c = 0; c < parts; ++c) out[c] = uint16_t(acc[c] / uint32_t(trees));
}

void Pipeline::votes_and_proposals(const CameraIntrinsics& intrinsics, const uint8_t* user_filter, int32_t user_stride,
                                   uint8_t user_id, uint64_t t0, FrameResult* r) {
  DP_DCHECK(s_.initialized && usable(intrinsics));
  DP_DCHECK(s_.evaluated_count >= 1 && s_.evaluated_count <= s_.max_pixels);
  const kernels::KernelSet k = kernels::kernel_set(s_.kernel, s_.forest_kernel);
  const VoteSets sets{s_.votes, s_.vote_counts, s_.select_keys};
  const CastInputs in{&s_.blob,      s_.config,    s_.pixels,         s_.evaluated_count,
                      s_.leaves,     s_.max_pixels, intrinsics,       user_filter,
                      user_stride,   user_id,       r->votes_per_joint_used, s_.joint_mass,
                      s_.guess_hist, OjrVoteTable{s_.ojr_live_offsets, s_.ojr_live_votes, s_.ojr_live_lanes}};
  const VoteScanKernels scan{k.bpc_scan, k.ojr_scan};
  r->flags |= cast_votes(in, k.bpc_scan ? &scan : nullptr, sets);
  const uint64_t t1 = cycle_count();
  r->stage_cycles[kStageVotes] = t1 - t0;
  aggregate_proposals(*s_.config, s_.blob.meta->joint_count, sets,
                      MeanShiftScratch{s_.starts, s_.modes, s_.soa, s_.cell_keys, s_.cell_ids},
                      MeanShiftKernels{k.mean_shift_sums, k.mode_weights}, r);
  const uint64_t t2 = cycle_count();
  r->stage_cycles[kStageMeanShift] = t2 - t1;
}

Status Pipeline::process(const DepthFrame& f, FrameResult* r) {
  if (!r) return Status::kBadArgument;
  memset(r, 0, sizeof *r);
  if (!s_.initialized) return Status::kNotInitialized;
  if (!f.depth_mm || f.width < 1 || f.height < 1 || f.stride_px < f.width || !usable(f.intrinsics))
    return Status::kBadArgument;
  if (f.width > s_.max_width || f.height > s_.max_height) return Status::kFrameTooLarge;
  const blob::RuntimeConfig& cfg = *s_.config;
  const kernels::KernelSet k = kernels::kernel_set(s_.kernel, s_.forest_kernel);
  r->joint_count = s_.blob.meta->joint_count;
  const uint64_t t0 = cycle_count();

  // Stage 1: foreground → probe image and the (possibly strided) list of pixels to evaluate. The
  // scan lists the foreground in raster order (what an unstrided frame evaluates); a frame over its
  // pixel budget is listed again with a stride.
  const int32_t pixel_cap = int32_t(cfg.max_evaluated_pixels) < s_.max_pixels ? int32_t(cfg.max_evaluated_pixels)
                                                                              : s_.max_pixels;
  const kernels::ForegroundScanResult scan =
      list_foreground(k.foreground, f, cfg, s_.probe_image, s_.pixels, pixel_cap);
  r->foreground_pixels = scan.foreground;
  const BudgetPlan plan = plan_budget(s_.blob, cfg, f.width * f.height, scan.foreground, pixel_cap);
  r->flags |= plan.flags;
  r->votes_per_joint_used = plan.votes;
  r->starts_per_joint_used = plan.starts;
  r->iterations_used = plan.iterations;
  r->predicted_cycles = plan.predicted;
  int32_t stride = 1;
  const int32_t n = thin_to_budget(s_.probe_image, f.width, f.height, scan.foreground, plan.pixels, s_.pixels, &stride);
  if (stride > 1) r->flags |= kFlagPixelsStrided;
  r->pixel_stride = stride;
  s_.evaluated_count = n;
  r->evaluated_pixels = n;
  const uint64_t t1 = cycle_count();
  r->stage_cycles[kStageForeground] = t1 - t0;
  if (n == 0) {
    r->flags |= kFlagNoForeground;
    r->total_cycles = t1 - t0;
    return Status::kOk;
  }

  // Stage 2: the forest.
  evaluate_forest(k.forest, s_.blob, s_.split_nodes, s_.leaf_index, s_.probe_image, f.width, f.height,
                  0.5f * (f.intrinsics.fx + f.intrinsics.fy), s_.pixels, n, s_.leaves, s_.max_pixels);
  const uint64_t t2 = cycle_count();
  r->stage_cycles[kStageForest] = t2 - t1;

  // Stages 3 and 4: votes and mean shift.
  votes_and_proposals(f.intrinsics, nullptr, 0, 0, t2, r);
  r->total_cycles = cycle_count() - t0;
  if (cfg.cycle_budget != 0 && r->total_cycles > cfg.cycle_budget) r->flags |= kFlagOverCycleBudget;
  return Status::kOk;
}

Status Pipeline::process_user(const DepthFrame& f, uint8_t user_id, FrameResult* r) {
  if (!r) return Status::kBadArgument;
  memset(r, 0, sizeof *r);
  if (!s_.initialized) return Status::kNotInitialized;
  if (!f.foreground_mask || user_id == 0 || f.stride_px < f.width || f.width > s_.max_width ||
      f.height > s_.max_height || !usable(f.intrinsics))
    return Status::kBadArgument;
  r->joint_count = s_.blob.meta->joint_count;
  const uint64_t t0 = cycle_count();
  int32_t mine = 0;
  for (int32_t i = 0; i < s_.evaluated_count; ++i) {
    DP_DCHECK(s_.pixels[i].u < f.width && s_.pixels[i].v < f.height);  // the frame of the last process()
    mine += f.foreground_mask[size_t(s_.pixels[i].v) * size_t(f.stride_px) + s_.pixels[i].u] == user_id;
  }
  r->evaluated_pixels = mine;
  if (mine == 0) {
    r->flags |= kFlagNoForeground;
    r->total_cycles = cycle_count() - t0;
    return Status::kOk;
  }
  // No cycle-budget plan here: the frame's own process() already planned; its limits apply as configured.
  r->votes_per_joint_used = s_.config->max_votes_per_joint;
  r->starts_per_joint_used = s_.config->max_starts_per_joint;
  r->iterations_used = s_.config->mean_shift_iterations;
  votes_and_proposals(f.intrinsics, f.foreground_mask, f.stride_px, user_id, t0, r);
  r->total_cycles = cycle_count() - t0;
  return Status::kOk;
}

Status Pipeline::aggregate_from_leaves(const CameraIntrinsics& intr, const EvaluatedPixel* pixels,
                                       const uint32_t* leaves, int32_t count, FrameResult* r) {
  if (!r) return Status::kBadArgument;
  memset(r, 0, sizeof *r);
  if (!s_.initialized) return Status::kNotInitialized;
  if (!pixels || !leaves || count < 1 || count > s_.max_pixels || !usable(intr)) return Status::kBadArgument;
  const int trees = s_.blob.tree_count();
  for (size_t k = 0; k < size_t(count) * size_t(trees); ++k)
    if (leaves[k] >= s_.blob.meta->leaf_count) return Status::kBadArgument;
  const uint64_t t0 = cycle_count();
  memcpy(s_.pixels, pixels, size_t(count) * sizeof(EvaluatedPixel));
  for (int t = 0; t < trees; ++t)
    memcpy(s_.leaves + size_t(t) * s_.max_pixels, leaves + size_t(t) * count, size_t(count) * sizeof(uint32_t));
  s_.evaluated_count = count;
  r->joint_count = s_.blob.meta->joint_count;
  r->evaluated_pixels = count;
  r->foreground_pixels = count;
  r->pixel_stride = 1;
  // No cycle-budget plan here (the frame size is unknown): the config's limits apply as they are.
  r->votes_per_joint_used = s_.config->max_votes_per_joint;
  r->starts_per_joint_used = s_.config->max_starts_per_joint;
  r->iterations_used = s_.config->mean_shift_iterations;
  votes_and_proposals(intr, nullptr, 0, 0, t0, r);
  r->total_cycles = cycle_count() - t0;
  return Status::kOk;
}

}  // namespace dp
