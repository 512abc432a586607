// `depthpose run`: the app loop. One blob, one source, one pipeline, one JSON line per frame.
//
// Memory: the blob bytes, the arena (required_arena_bytes for the source's frame size), the frame
// buffer, the overlay image, the JSON line buffer, the frame-time histogram and, with
// segmentation, the segmenter's arena, label image, one-user mask and per-user results are
// allocated once before the first frame; the per-frame loop allocates nothing (PNG encoding for --overlay happens
// inside libpng, which keeps its own state).
//
// Output (stdout with --json), one line per processed frame:
//   {"frame":N,"source_index":I,"timestamp_us":T,"frame_ms":F,"kernel":"avx2",
//    "joints":[{"name":"head","x":..,"y":..,"z":..,"confidence":..,"state":..,"vote_weight":..,
//               "orientation":[w,x,y,z]|null}, ... ],
//             // the skeleton tracker's joints when the blob has its 16 joints ("skeleton":true:
//             // confidence in [0, 1], state tracked/inferred/missing, docs/skeleton.md); otherwise
//             // the best proposal (confidence = its vote weight); x/y/z metres, null when missing
//    "skeleton":true|false,
//    "proposals":[[[x,y,z,c],...], ...],      // only with --all-proposals, per joint
//    "stage_cycles":{"foreground":..,"forest":..,"votes":..,"mean_shift":..},"total_cycles":..,
//    "flags":["pixels_strided",...],"over_budget":false,
//    "foreground_pixels":..,"evaluated_pixels":..,"pixel_stride":..,
//    // with segmentation (--segment on, or auto on a live or .oni source):
//    "primary_user":1|null,                 // the user with the most pixels
//    "users":[{"id":1,"pixels":..,"centroid":[x,y,z],"frames_tracked":..,"joints":[...same as above...],
//              "cycles":..,"evaluated_pixels":..,"flags":[..]}, ...],  // by increasing id; ids stable
//    "segmentation":{"floor":[nx,ny,nz,d]|null,"candidate_pixels":..,"flags":[..],
//                    "stage_cycles":{"floor":..,"background":..,"components":..,"users":..}},
//    "frame_cycles":..}                     // segmentation + every user's pass
// With segmentation the pipeline runs once per user over that user's pixels alone (the other
// people are background to its probes, as in training); the top-level "joints" are the primary
// user's, the top-level cycles and pixel counts summed over users, the flags or-ed.
// Without --json each processed frame prints one text line instead:
//   frame 3 (source 3, 0.41 ms): head 0.012 0.457 2.055 (812) | neck - | ...
// and, with segmentation, one more line per user:
//   frame 3 user 1 (5321 px, tracked 4 frames): head ... | ...
// Events (device lost/back, skipped corrupt frames) and the closing summary go to `log`.
#pragma once
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>

#include "platform/frame_source.h"
#include "runtime/depthpose.h"
#include "runtime/skeleton_filter.h"
#include "tools/common/budget_options.h"

namespace dp::tools {

// Segmentation (dp::Segmenter, docs/segmentation.md) before the forest: floor, background model,
// users with stable ids. kAuto = on for live sources and .oni recordings (a room, a fixed camera:
// background model on), off for raw files and datasets (frames usually already cut out; a dataset
// with --floor wants kOn). kOn on raw/dataset sources leaves the background model off (their
// frames may be unrelated).
enum class SegmentMode { kAuto, kOn, kOff };

struct RunOptions {
  std::string blob_path;
  std::string source_spec;
  platform::SourceOptions source_options;
  bool json = false;             // JSON lines on json_out; otherwise one short text line per frame
  bool quiet = false;            // no per-frame output at all (summary only)
  bool all_proposals = false;
  // The skeleton tracker's temporal filter (runtime/skeleton_filter.h, docs/skeleton.md).
  SkeletonFilterPreset smoothing = SkeletonFilterPreset::kDefault;
  std::string overlay_dir;      // empty = no overlays
  int every = 1;                // process every N-th frame of the source
  bool realtime = false;        // pace files at their timestamps; drop frames when late
  int64_t max_frames = -1;      // stop after this many processed frames (−1 = source end)
  int64_t loop = 1;             // play a file source this many times (rewound at its end; soaks)
  KernelIsa kernel = KernelIsa::kBest;
  SegmentMode segment = SegmentMode::kAuto;
  std::string segment_config_path;  // SegmenterConfig file over the defaults (empty = defaults)
  BudgetOverrides budget;        // --pixel-budget / --cycle-budget over the blob's config (docs/budget.md)
  // Live sources: watch the USB bus (libusb) for the depth camera leaving and coming back.
  bool usb_watch = true;
  // Called after each processed frame (tests observe the loop with it). May be empty.
  std::function<void(int64_t frames_processed)> on_frame;
};

struct RunSummary {
  int64_t frames_processed = 0;
  int64_t frames_read = 0;        // delivered by the source (processed + skipped by --every + dropped)
  int64_t skipped_by_every = 0;
  int64_t dropped = 0;            // --realtime drops + frames the live device produced unread
  int64_t corrupt = 0;            // skipped by the source
  int64_t overruns = 0;           // frames flagged kFlagOverCycleBudget
  int64_t degraded = 0;           // frames that did less work than the config asks: pixels strided
                                  // (pixel budget) or any kFlagBudget* flag (cycle budget)
  int64_t capped = 0;             // frames where a top-N cap applied (votes above Nsub, starts,
                                  // proposals): the method's normal operation, not a degradation
  int64_t device_lost = 0, reconnects = 0;
  double seconds = 0, fps = 0;    // wall time of the loop; processed frames per second
  double p50_ms = 0, p99_ms = 0, max_ms = 0;  // process() time per frame
  bool segmented = false;         // the Segmenter ran on every processed frame
  int64_t user_frames = 0;        // Σ over processed frames of the users found
  int max_users_in_frame = 0;
  int distinct_user_ids = 0;      // ids ever reported
  bool source_failed = false;
  std::string source_error;
};

// Runs the loop until the source ends (`loop` times), max_frames, a source error or
// stop_requested() (SIGINT). Throws ToolError for setup problems (blob, source, overlay directory,
// kernel, --loop on a live source). A source that delivered frames but none processable (every
// frame corrupt or refused) ends with source_failed and a source_error saying so.
RunSummary run_app(const RunOptions& options, FILE* json_out, FILE* log);


// Asks a running run_app to stop after the current frame (signal safe).
void request_stop();

}  // namespace dp::tools
