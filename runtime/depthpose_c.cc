// The C API (depthpose_c.h) over dp::Segmenter, dp::Pipeline and dp::SkeletonTracker, laid out
// in the caller's memory: the handle, then the pipeline arena, the segmenter arena, the label
// image and one-user mask, the per-user proposals and skeletons. The per-frame flow is the one of
// `depthpose run` with segmentation: each user's pixels alone go through the pipeline (the other
// people are background to its probes, as in training), then the tracker.
#include "runtime/depthpose_c.h"

#include <new>
#include <string.h>

#include "runtime/arena.h"
#include "runtime/depthpose.h"
#include "runtime/segmentation/segmenter.h"
#include "runtime/skeleton_tracker.h"

static_assert(DP_JOINT_COUNT == dp::kSkeletonJoints, "C joint count");
static_assert(DP_MAX_USERS == dp::kMaxUsers, "C user count");
static_assert(DP_MEMORY_ALIGNMENT == dp::kArenaAlignment, "C memory alignment");

struct dp_tracker {
  uint32_t magic;  // kOpenMagic while open
  dp::blob::LoadedBlob blob;
  int32_t max_width, max_height;
  int32_t width, height, stride;  // of the last processed frame (0 before any)
  dp::Pipeline pipeline;
  dp::Segmenter segmenter;
  dp::SkeletonTracker skeletons;
  dp::SegmentationResult segmentation;
  uint8_t* labels;        // max_width · max_height
  uint8_t* user_mask;     // max_width · max_height
  dp::FrameResult* proposals;   // one user's, reused
  dp::Skeleton* user_skeletons; // [kMaxUsers], by index in segmentation.users
};

namespace {

constexpr uint32_t kOpenMagic = 0x64707472u;  // "dptr"

// The carve of the caller's memory; `base` null counts only.
struct Layout {
  dp_tracker* handle;
  uint8_t* pipeline_arena;
  size_t pipeline_bytes;
  uint8_t* segmenter_arena;
  size_t segmenter_bytes;
  uint8_t* labels;
  uint8_t* user_mask;
  dp::FrameResult* proposals;
  dp::Skeleton* skeletons;
};

bool carve(const dp::blob::LoadedBlob& blob, int32_t w, int32_t h, uint8_t* base, size_t bytes, Layout* l, size_t* used) {
  l->pipeline_bytes = dp::required_arena_bytes(blob, w, h);
  l->segmenter_bytes = dp::segmenter_required_bytes(w, h);
  if (!l->pipeline_bytes || !l->segmenter_bytes) return false;
  dp::ArenaCarver c(base, bytes);
  l->handle = c.head<dp_tracker>(1);
  l->pipeline_arena = c.head<uint8_t>(l->pipeline_bytes);
  l->segmenter_arena = c.head<uint8_t>(l->segmenter_bytes);
  l->labels = c.head<uint8_t>(size_t(w) * size_t(h));
  l->user_mask = c.head<uint8_t>(size_t(w) * size_t(h));
  l->proposals = c.head<dp::FrameResult>(1);
  l->skeletons = c.head<dp::Skeleton>(dp::kMaxUsers);
  *used = c.used();
  return c.ok();
}

bool open(const dp_tracker* t) { return t && t->magic == kOpenMagic; }

dp_status from(dp::Status s) {
  switch (s) {
    case dp::Status::kOk: return DP_OK;
    case dp::Status::kArenaTooSmall: return DP_ERROR_MEMORY_TOO_SMALL;
    case dp::Status::kArenaMisaligned: return DP_ERROR_MEMORY_MISALIGNED;
    case dp::Status::kFrameTooLarge: return DP_ERROR_FRAME_TOO_LARGE;
    case dp::Status::kNotInitialized: return DP_ERROR_NOT_OPEN;
    default: return DP_ERROR_ARGUMENT;
  }
}

bool load(const void* blob, size_t blob_bytes, dp::blob::LoadedBlob* out) {
  return blob && blob_bytes > 0 && dp::blob::load_blob(blob, blob_bytes, out) == dp::blob::BlobStatus::kOk;
}

}  // namespace

extern "C" {

uint32_t dp_api_version(void) { return DP_API_VERSION; }

const char* dp_status_message(dp_status s) {
  switch (s) {
    case DP_OK: return "ok";
    case DP_ERROR_ARGUMENT: return "bad argument (null pointer, size, stride or intrinsics)";
    case DP_ERROR_BLOB: return "not a valid depthpose blob (or not 8-byte aligned)";
    case DP_ERROR_JOINT_SET: return "the blob's joints are not the 16 skeleton joints";
    case DP_ERROR_MEMORY_TOO_SMALL: return "memory smaller than dp_tracker_memory_bytes()";
    case DP_ERROR_MEMORY_MISALIGNED: return "memory not 64-byte aligned";
    case DP_ERROR_FRAME_TOO_LARGE: return "frame larger than the maximum given to dp_tracker_open";
    case DP_ERROR_NOT_OPEN: return "tracker not open";
    case DP_ERROR_INDEX: return "user index out of range";
  }
  return "unknown status";
}

const char* dp_joint_name(int32_t joint) { return dp::skeleton_joint_name(joint); }

size_t dp_tracker_memory_bytes(const void* blob, size_t blob_bytes, int32_t max_width, int32_t max_height) {
  dp::blob::LoadedBlob b;
  if (!load(blob, blob_bytes, &b)) return 0;
  Layout l;
  size_t used = 0;
  return carve(b, max_width, max_height, nullptr, size_t(-1) / 2, &l, &used) ? used : 0;
}

dp_status dp_tracker_open(const void* blob, size_t blob_bytes, int32_t max_width, int32_t max_height, void* memory,
                          size_t memory_bytes, dp_tracker** out) {
  if (out) *out = nullptr;
  if (!out || !memory || max_width < 1 || max_height < 1 || max_width > dp::blob::kMaxFrameDimension ||
      max_height > dp::blob::kMaxFrameDimension)
    return DP_ERROR_ARGUMENT;
  if (reinterpret_cast<uintptr_t>(memory) % dp::kArenaAlignment != 0) return DP_ERROR_MEMORY_MISALIGNED;
  dp::blob::LoadedBlob b;
  if (!load(blob, blob_bytes, &b)) return DP_ERROR_BLOB;
  Layout l;
  size_t used = 0;
  if (!carve(b, max_width, max_height, nullptr, size_t(-1) / 2, &l, &used)) return DP_ERROR_ARGUMENT;
  if (memory_bytes < used) return DP_ERROR_MEMORY_TOO_SMALL;
  carve(b, max_width, max_height, static_cast<uint8_t*>(memory), memory_bytes, &l, &used);
  dp_tracker* t = new (l.handle) dp_tracker();
  t->blob = b;
  t->max_width = max_width;
  t->max_height = max_height;
  t->labels = l.labels;
  t->user_mask = l.user_mask;
  t->proposals = l.proposals;
  t->user_skeletons = l.skeletons;
  if (t->skeletons.init(*b.meta, dp::default_skeleton_config()) != dp::Status::kOk) return DP_ERROR_JOINT_SET;
  if (dp::Status s = t->pipeline.init(b, max_width, max_height, l.pipeline_arena, l.pipeline_bytes); s != dp::Status::kOk)
    return from(s);
  // A tracker serves a fixed camera frame after frame: the live configuration (background model on).
  if (dp::Status s = t->segmenter.init(dp::default_segmenter_config(true), max_width, max_height, l.segmenter_arena,
                                       l.segmenter_bytes);
      s != dp::Status::kOk)
    return from(s);
  t->magic = kOpenMagic;
  *out = t;
  return DP_OK;
}

dp_status dp_tracker_set_smoothing(dp_tracker* t, int32_t smoothing) {
  if (!open(t)) return DP_ERROR_NOT_OPEN;
  if (smoothing < DP_SMOOTHING_OFF || smoothing > DP_SMOOTHING_STRONG) return DP_ERROR_ARGUMENT;
  dp::SkeletonConfig c = t->skeletons.config();
  c.filter = dp::skeleton_filter_preset(static_cast<dp::SkeletonFilterPreset>(smoothing));
  return from(t->skeletons.set_config(c));
}

dp_status dp_tracker_process(dp_tracker* t, const uint16_t* depth_mm, int32_t width, int32_t height, int32_t stride_px,
                             const dp_intrinsics* intrinsics) {
  if (!open(t)) return DP_ERROR_NOT_OPEN;
  t->segmentation.user_count = 0;
  t->width = t->height = t->stride = 0;
  if (!depth_mm || !intrinsics || width < 1 || height < 1 || stride_px < width) return DP_ERROR_ARGUMENT;
  if (width > t->max_width || height > t->max_height) return DP_ERROR_FRAME_TOO_LARGE;
  // The label image is written with the frame's stride; ours holds max_width per row, so a wider
  // stride is refused rather than overrun.
  if (stride_px > t->max_width) return DP_ERROR_FRAME_TOO_LARGE;
  const dp::DepthFrame frame{depth_mm, width, height, stride_px,
                             {intrinsics->fx, intrinsics->fy, intrinsics->cx, intrinsics->cy}, t->labels};
  t->segmentation.labels = t->labels;
  if (dp::Status s = t->segmenter.process(frame, &t->segmentation); s != dp::Status::kOk) {
    t->segmentation.user_count = 0;
    return from(s);
  }
  t->skeletons.begin_frame();
  const size_t pixels = size_t(height) * size_t(stride_px);
  for (int32_t i = 0; i < t->segmentation.user_count; ++i) {
    const uint8_t id = uint8_t(t->segmentation.users[i].id);
    for (size_t p = 0; p < pixels; ++p) t->user_mask[p] = t->labels[p] == id;
    dp::DepthFrame own = frame;
    own.foreground_mask = t->user_mask;
    if (dp::Status s = t->pipeline.process(own, t->proposals); s != dp::Status::kOk) {
      t->segmentation.user_count = 0;
      return from(s);
    }
    t->skeletons.note_arrival(id, t->segmentation.users[i].arrival);
    t->skeletons.update(id, *t->proposals, &t->user_skeletons[i]);
  }
  t->width = width;
  t->height = height;
  t->stride = stride_px;
  return DP_OK;
}

int32_t dp_tracker_user_count(const dp_tracker* t) { return open(t) ? t->segmentation.user_count : 0; }

dp_status dp_tracker_get_user(const dp_tracker* t, int32_t index, dp_user* out) {
  if (!open(t)) return DP_ERROR_NOT_OPEN;
  if (!out) return DP_ERROR_ARGUMENT;
  if (index < 0 || index >= t->segmentation.user_count) return DP_ERROR_INDEX;
  const dp::UserInfo& u = t->segmentation.users[index];
  const dp::Skeleton& s = t->user_skeletons[index];
  memset(out, 0, sizeof *out);
  out->id = u.id;
  out->pixel_count = u.pixel_count;
  out->frames_tracked = u.frames_tracked;
  for (int k = 0; k < 3; ++k) out->centroid[k] = u.centroid_m[k];
  for (int j = 0; j < DP_JOINT_COUNT; ++j) {
    const dp::TrackedJoint& tj = s.joints[j];
    const float* q = s.bone_rotation[j];
    out->joints[j] = {tj.x_m, tj.y_m, tj.z_m, tj.confidence, int32_t(tj.state), {q[0], q[1], q[2], q[3]},
                      s.bone_rotation_valid[j]};
  }
  return DP_OK;
}

const uint8_t* dp_tracker_user_map(const dp_tracker* t, int32_t* width, int32_t* height, int32_t* stride) {
  const bool have = open(t) && t->width > 0;
  if (width) *width = have ? t->width : 0;
  if (height) *height = have ? t->height : 0;
  if (stride) *stride = have ? t->stride : 0;
  return have ? t->labels : nullptr;
}

dp_status dp_tracker_get_floor(const dp_tracker* t, dp_floor* out) {
  if (!open(t)) return DP_ERROR_NOT_OPEN;
  if (!out) return DP_ERROR_ARGUMENT;
  const dp::FloorPlane& f = t->segmentation.floor;
  const bool have = t->width > 0 && f.valid;
  *out = {have ? f.nx : 0.0f, have ? f.ny : 0.0f, have ? f.nz : 0.0f, have ? f.d : 0.0f, have ? 1 : 0};
  return DP_OK;
}

void dp_tracker_close(dp_tracker* t) {
  if (open(t)) t->magic = 0;
}

}  // extern "C"
