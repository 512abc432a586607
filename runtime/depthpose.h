// depthpose runtime: one depth frame in, confidence-weighted 3D joint proposals out.
//
// Contract (firmware style):
//   - The caller owns all memory. required_arena_bytes() says how much; init() takes it.
//     Persistent state lives at the arena's tail, per-frame scratch at its head and is reset
//     at the start of every process() call. Nothing allocates or throws after (or during) init.
//   - The blob must have been accepted by dp::blob::load_blob(); its bytes must outlive the
//     Pipeline. After init() every loop is bounded by values validated at load time.
//   - process() is deterministic: the same blob, config, kernel and frame give the same result
//     bit for bit, whichever kernel (scalar reference, AVX2, AVX-512, NEON) evaluates the forest.
//   - A Pipeline owns its view of the arena: it can be moved (the source is left uninitialised)
//     but not copied (two copies would share one arena's scratch).
//   - Costs are in counter ticks (runtime/cycle_counter.h: TSC cycles on x86-64, CNTVCT_EL0 ticks
//     on aarch64).
// Dataflow (docs/architecture.md maps each stage to its file): foreground.h → forest.h → votes.h
// (bpc_votes.h, ojr_votes.h, vote_selection.h) → mean_shift.h, planned by budget_plan.h.
// Units: depth uint16 millimetres (0 = no reading); 3D points in metres in the camera frame
// (OpenNI convention: x right, y up, z forward): x = (u − cx)·z/fx, y = −(v − cy)·z/fy.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "forest_blob/blob_loader.h"

namespace dp {

namespace kernels {
struct SplitNode;  // runtime/kernels/forest_kernel.h
}  // namespace kernels

enum class Status : int32_t {
  kOk = 0,
  kBadArgument,        // null pointer, non-positive size, stride < width, bad intrinsics
  kArenaTooSmall,      // init: arena smaller than minimum_arena_bytes()
  kArenaMisaligned,    // init: arena not 64-byte aligned
  kFrameTooLarge,      // process: frame larger than the max size given to init
  kNotInitialized,     // process before a successful init
  kBadConfig,          // set_config: values outside the documented ranges
  kKernelUnavailable,  // set_kernel: this CPU lacks the instruction set
};
const char* status_message(Status status);

constexpr int kMaxJoints = blob::kMaxJoints;
constexpr int kMaxProposals = blob::kMaxProposalsCap;

struct CameraIntrinsics {
  float fx, fy;  // focal lengths in pixels, finite and > 0
  float cx, cy;  // principal point in pixels, finite
};

struct DepthFrame {
  const uint16_t* depth_mm;    // row-major, `stride_px` elements per row
  int32_t width, height;       // pixels, ≥ 1
  int32_t stride_px;           // ≥ width
  CameraIntrinsics intrinsics;
  // Optional foreground mask (nonzero = person), same geometry as depth (stride_px). When null,
  // foreground = pixels with config.near_mm ≤ depth ≤ config.far_mm.
  const uint8_t* foreground_mask;
};

struct JointProposal {
  float x_m, y_m, z_m;  // camera frame, metres
  float confidence;     // Σ vote weights (p·z² for BPC, w·z² for OJR; z in metres)
};

enum Stage : int32_t {
  kStageForeground = 0,  // mask/band → pixel list + probe image
  kStageForest,          // tree traversal for every evaluated pixel
  kStageVotes,           // vote casting and bounded top-N selection
  kStageMeanShift,       // aggregation into proposals
  kStageSkeleton,        // the skeleton tracker (runtime/skeleton_tracker.h), run by its caller after
                         // the pipeline; Pipeline::process leaves it 0
  kStageCount
};
const char* stage_name(int32_t stage);

// Budget flags: set when the pipeline degraded to stay within its bounds (docs/budget.md).
enum FrameFlag : uint32_t {
  kFlagNoForeground = 1u << 0,       // no foreground pixel: no proposals
  kFlagPixelsStrided = 1u << 1,      // foreground > max_evaluated_pixels: pixels were strided
  kFlagVotesTruncated = 1u << 2,     // a joint had more votes than max_votes_per_joint
  kFlagStartsTruncated = 1u << 3,    // a joint had more starting points than max_starts_per_joint
  kFlagProposalsTruncated = 1u << 4, // a joint had more modes than max_proposals_per_joint
  kFlagOverCycleBudget = 1u << 5,    // the frame took more cycles than config.cycle_budget
  // The cycle budget's plan (docs/budget.md) degraded, in this order:
  kFlagBudgetPixels = 1u << 6,       // fewer evaluated pixels than max_evaluated_pixels (stride)
  kFlagBudgetVotes = 1u << 7,        // Nsub below max_votes_per_joint
  kFlagBudgetStarts = 1u << 8,       // mean-shift starts below max_starts_per_joint
  kFlagBudgetIterations = 1u << 9,   // mean-shift iterations below mean_shift_iterations
  kFlagBudgetInfeasible = 1u << 10,  // even fully degraded the predicted cost exceeds the budget
};
constexpr int32_t kFrameFlagBits = 11;

// The snake_case name of FrameFlag bit `bit` ("pixels_strided", "budget_votes", ...), as the tools print
// it; "unknown_flag" outside 0..kFrameFlagBits−1.
inline const char* frame_flag_name(int32_t bit) {
  constexpr const char* kNames[kFrameFlagBits] = {
      "no_foreground",  "pixels_strided", "votes_truncated", "starts_truncated",  "proposals_truncated",
      "over_cycle_budget", "budget_pixels", "budget_votes",   "budget_starts",    "budget_iterations",
      "budget_infeasible"};
  return bit >= 0 && bit < kFrameFlagBits ? kNames[bit] : "unknown_flag";
}

struct FrameResult {
  int32_t joint_count;                         // = blob joint_count
  int32_t proposal_count[kMaxJoints];          // per joint, ≤ config.max_proposals_per_joint
  JointProposal proposals[kMaxJoints][kMaxProposals];  // per joint, by decreasing confidence
  uint64_t stage_cycles[kStageCount];          // counter ticks per stage (runtime/cycle_counter.h)
  uint64_t total_cycles;
  uint32_t flags;                              // FrameFlag bits
  int32_t foreground_pixels;                   // before striding
  int32_t evaluated_pixels;                    // pixels the forest ran on
  int32_t pixel_stride;                        // 1 unless kFlagPixelsStrided
  // What the cycle-budget plan allowed this frame (= the config's values when nothing degraded).
  int32_t votes_per_joint_used;                // Nsub
  int32_t starts_per_joint_used;
  int32_t iterations_used;
  uint64_t predicted_cycles;                   // the plan's worst-case cost model (docs/budget.md)
};

enum class KernelIsa : int32_t { kScalar = 0, kAvx2 = 1, kAvx512 = 2, kBest = 3, kNeon = 4 };
const char* kernel_isa_name(KernelIsa isa);
bool kernel_isa_supported(KernelIsa isa);
// What kBest means for the forest kernel: AVX2 when present (else scalar). On split nodes it measured
// faster than the AVX-512 kernel (docs/runtime_speed.md, the layout study: a visit's scalar threshold
// load is cheaper than its share of the 8-pixel step's lane decode, and 256-bit ops issue on more
// ports). The other kernels' kBest is the widest available. Results are the same whichever runs.
KernelIsa best_forest_kernel_isa();
// On aarch64 both are NEON (part of the base architecture).
// What kBest means for every other kernel: the widest ISA this build and CPU run (AVX-512, else AVX2,
// else NEON, else scalar).
KernelIsa widest_kernel_isa();

// A pixel the forest evaluated (for tools: segmentation output, overlays).
struct EvaluatedPixel {
  uint16_t u, v;   // image coordinates
  uint16_t z_mm;   // depth
  uint16_t reserved;
};

// Bytes init() needs for frames up to max_width × max_height (0 when the arguments are invalid):
// the frame's scratch, the forest's traversal tables (20 bytes per tree node, made from the blob at
// init: a 16-byte kernels::SplitNode, one cache line per visit, and the node's leaf record; shipped
// BPC: 12.4 MB) and, for OJR, the optional live-vote copy (ojr_votes.h: 4 bytes per leaf record
// and 9 per stored vote; shipped OJR: 5.5 MB), which the fast vote caster reads instead of every
// stored vote.
size_t required_arena_bytes(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height);
// The least init() accepts: the same without the optional copy (the caster then reads the blob's
// votes in place; results are identical). Equal to required_arena_bytes for BPC.
size_t minimum_arena_bytes(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height);

class Pipeline {
 public:
  Pipeline() = default;
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;
  // Moving hands the arena view over; the source is left as a default-constructed Pipeline.
  Pipeline(Pipeline&& other) noexcept;
  Pipeline& operator=(Pipeline&& other) noexcept;

  // Carves state out of `arena` (64-byte aligned, ≥ minimum_arena_bytes; the optional copy is
  // made when it is ≥ required_arena_bytes) and builds the traversal tables in it. Copies the blob's RuntimeConfig into the arena
  // (set_config may change it later). Selects KernelIsa::kBest.
  // Returns kOk, kBadArgument, kArenaTooSmall (below minimum_arena_bytes) or kArenaMisaligned.
  Status init(const blob::LoadedBlob& blob, int32_t max_width, int32_t max_height, uint8_t* arena,
              size_t arena_bytes);

  // Runs the whole chain on one frame. Returns kOk, kNotInitialized, kBadArgument (null pointer,
  // non-positive size, stride < width, intrinsics not finite or a focal length ≤ 0) or
  // kFrameTooLarge; on error `result` is zeroed and no proposals are reported.
  Status process(const DepthFrame& frame, FrameResult* result);

  // Per-user joints (runtime/segmentation/segmenter.h). After process() on a frame whose
  // foreground_mask holds user ids (0 = background, 1..255 = user; e.g. Segmenter labels), casts
  // and aggregates only the votes of the evaluated pixels labelled `user_id` into `result`; the
  // forest is not run again. `frame` must be the frame (and mask) of the last process() call.
  // `result` gets that user's proposals, evaluated_pixels = its evaluated pixels, flags, and the
  // cycles of this call in stage_cycles[kStageVotes], [kStageMeanShift] and total_cycles.
  // kBadArgument for a null result, a null mask or user_id 0; kNotInitialized before init.
  Status process_user(const DepthFrame& frame, uint8_t user_id, FrameResult* result);

  // Chooses the kernels (tests and benchmarks compare them). kKernelUnavailable if this build or
  // CPU lacks it. kBest picks the widest available (the forest kernel: best_forest_kernel_isa()).
  // kScalar selects the plain C++ reference kernels and vote casters (the specification); every other
  // choice uses that ISA's kernels as runtime/kernels/dispatch.h lists them, which give exactly the
  // same votes and proposals (tests/runtime_kernel_test.cc proves it).
  Status set_kernel(KernelIsa isa);
  KernelIsa kernel() const { return s_.kernel; }                // the vote and mean-shift kernels' ISA
  KernelIsa forest_kernel() const { return s_.forest_kernel; }  // the forest kernel's (differs under kBest)

  const blob::RuntimeConfig& config() const { return *s_.config; }
  // Validates then replaces the runtime config (tune uses this). kBadConfig on invalid values.
  Status set_config(const blob::RuntimeConfig& config);

  // Re-runs only votes and mean shift (stages 3–4) with the current config, on a pixel list and
  // its leaves saved from an earlier process() of a frame with these intrinsics (tune's grid
  // search re-aggregates cached forest output). `leaves` is tree-major: tree t's leaf for pixel i
  // at leaves[t · count + i]. Returns kNotInitialized, kBadArgument (null pointer, count outside
  // 1..pixel budget, intrinsics as for process(), a leaf ≥ leaf_count) or kOk;
  // stage_cycles[kStageForest] = 0.
  // Afterwards the views below describe the given pixels.
  Status aggregate_from_leaves(const CameraIntrinsics& intrinsics, const EvaluatedPixel* pixels,
                               const uint32_t* leaves, int32_t count, FrameResult* result);

  // Views of the last processed frame, valid until the next process() call.
  int32_t evaluated_pixel_count() const { return s_.evaluated_count; }
  const EvaluatedPixel* evaluated_pixels() const { return s_.pixels; }
  // Leaf record index (into the blob's leaf table) reached by evaluated pixel i in tree t.
  uint32_t leaf_of(int32_t pixel_index, int32_t tree) const {
    return s_.leaves[size_t(tree) * size_t(s_.max_pixels) + size_t(pixel_index)];
  }
  // BPC: p(c|u) for evaluated pixel i averaged over trees (Eq. 5), Q15, part_count entries.
  void part_distribution(int32_t pixel_index, uint16_t* probability_q15) const;

  size_t arena_used_bytes() const { return s_.arena_used; }
  bool uses_ojr_live_votes() const { return s_.ojr_live_offsets != nullptr; }
  const blob::LoadedBlob& blob() const { return s_.blob; }

 private:
  // Everything a Pipeline holds, so that a move can hand it over and reset the source in one step.
  struct State {
    blob::LoadedBlob blob{};
    blob::RuntimeConfig* config = nullptr;
    KernelIsa kernel = KernelIsa::kScalar, forest_kernel = KernelIsa::kScalar;
    int32_t max_width = 0, max_height = 0, max_pixels = 0;
    uint8_t* arena = nullptr;
    size_t arena_bytes = 0, arena_used = 0;
    // per-frame scratch (arena head)
    uint16_t* probe_image = nullptr;
    EvaluatedPixel* pixels = nullptr;
    uint32_t* leaves = nullptr;          // tree-major: [tree][max_pixels]
    struct Vote* votes = nullptr;        // [joint][kVoteSlots]
    int32_t* vote_counts = nullptr;
    uint32_t* select_keys = nullptr;     // vote cuts: 2·kVoteSlots
    uint16_t* guess_hist = nullptr;      // floor guesses: [kMaxJoints][kGuessBuckets]
    struct Vote* starts = nullptr;       // mean shift: [kMaxStartsCap]
    float* modes = nullptr;              //   [kMaxStartsCap][4]
    float* soa = nullptr;                //   [4][kSoaRow]
    uint64_t* cell_keys = nullptr;       //   [kCellSlots]
    int32_t* cell_ids = nullptr;         //   [kCellSlots]
    // persistent (arena tail)
    kernels::SplitNode* split_nodes = nullptr;  // traversal tables (forest.h build_forest_tables):
    uint32_t* leaf_index = nullptr;             //   total_nodes of each
    uint16_t* joint_mass = nullptr;      // BPC joint-mass table (bpc_votes.h), or nullptr
    uint32_t* ojr_live_offsets = nullptr;  // OJR live-vote copy (ojr_votes.h), or nullptr
    blob::OjrVote* ojr_live_votes = nullptr;
    uint8_t* ojr_live_lanes = nullptr;
    int32_t evaluated_count = 0;
    bool initialized = false;
  };
  State s_;

  // The shared tail of process, process_user and aggregate_from_leaves: votes (stage 3) and mean
  // shift (stage 4) over the listed pixels with the kernels of kernel(), timed from `t0` into
  // result's stage_cycles[kStageVotes], [kStageMeanShift] and total_cycles. Pixels whose value in
  // user_filter differs from user_id cast no votes (user_filter null: all cast).
  void votes_and_proposals(const CameraIntrinsics& intrinsics, const uint8_t* user_filter, int32_t user_stride,
                           uint8_t user_id, uint64_t t0, FrameResult* result);
};

}  // namespace dp
