/* depthpose C API: the whole online path — blob, depth frame in; users, skeleton joints (position,
 * state, confidence), the user map and the floor out — for C and any language with a C FFI.
 *
 * Contract (the runtime's, docs/skeleton.md "C API"):
 *   - Versioned: dp_api_version() returns DP_API_VERSION of the library; a program built against
 *     another major version must not use it. Additions keep the version; changes bump it.
 *   - Opaque handle, caller-owned memory: dp_tracker_memory_bytes() says how many bytes a tracker
 *     needs for a blob and a maximum frame size; dp_tracker_open() builds the tracker inside that
 *     memory (64-byte aligned) and returns a handle pointing into it. Nothing is allocated, ever;
 *     dp_tracker_close() only invalidates the handle (the caller then frees its memory).
 *   - The blob bytes (8-byte aligned) must stay valid and unchanged while the tracker is open.
 *   - Every function returns a dp_status (or a documented value) and never aborts on bad input;
 *     dp_status_message() names each status.
 *   - One tracker per thread at a time (no internal locking); separate trackers are independent.
 * Units: depth uint16 millimetres (0 = no reading); positions in metres in the camera frame (x
 * right, y up, z forward); a pixel (u, v) of depth z is at x = (u − cx)·z/fx, y = −(v − cy)·z/fy.
 * Joints: the 16 of docs/dataset_format.md, in the order of dp_joint_name(0..15). */
#ifndef DEPTHPOSE_C_H
#define DEPTHPOSE_C_H
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define DP_API_VERSION 1
#define DP_JOINT_COUNT 16
#define DP_MAX_USERS 15
#define DP_MEMORY_ALIGNMENT 64

typedef enum dp_status {
  DP_OK = 0,
  DP_ERROR_ARGUMENT = 1,          /* null pointer, non-positive size, stride < width, bad intrinsics */
  DP_ERROR_BLOB = 2,              /* the blob bytes are not a valid depthpose blob (or misaligned) */
  DP_ERROR_JOINT_SET = 3,         /* the blob's joints are not the 16 the skeleton needs */
  DP_ERROR_MEMORY_TOO_SMALL = 4,  /* fewer bytes than dp_tracker_memory_bytes() */
  DP_ERROR_MEMORY_MISALIGNED = 5, /* memory not DP_MEMORY_ALIGNMENT-byte aligned */
  DP_ERROR_FRAME_TOO_LARGE = 6,   /* frame larger than the maximum given to dp_tracker_open */
  DP_ERROR_NOT_OPEN = 7,          /* the handle was closed or never opened */
  DP_ERROR_INDEX = 8              /* user index outside 0..dp_tracker_user_count()−1 */
} dp_status;

typedef enum dp_joint_state {
  DP_JOINT_MISSING = 0,   /* no position */
  DP_JOINT_INFERRED = 1,  /* predicted from earlier frames, or a proposal that does not fit the body */
  DP_JOINT_TRACKED = 2    /* measured this frame and fits the body */
} dp_joint_state;

typedef enum dp_smoothing { DP_SMOOTHING_OFF = 0, DP_SMOOTHING_DEFAULT = 1, DP_SMOOTHING_STRONG = 2 } dp_smoothing;

typedef struct dp_intrinsics {
  float fx, fy; /* focal lengths in pixels, finite and > 0 */
  float cx, cy; /* principal point in pixels */
} dp_intrinsics;

typedef struct dp_joint {
  float x, y, z;     /* metres, camera frame; 0 when missing */
  float confidence;  /* [0, 1]: of joints reported at c, about a fraction c lie within 0.1 m of the truth */
  int32_t state;     /* dp_joint_state */
  /* The bone ending at this joint (from its parent: docs/skeleton.md): unit quaternion w, x, y, z
   * turning the bone's rest direction (T-pose facing the camera) into its direction, camera frame.
   * orientation_valid 0 (and the identity) for the neck and when either end is missing. */
  float orientation[4];
  int32_t orientation_valid;
} dp_joint;

typedef struct dp_user {
  int32_t id;              /* 1..DP_MAX_USERS, stable while the person stays in view, and given back to a person
                            * who left and returns within 5 s when the height matches (docs/skeleton.md);
                            * the value in the user map */
  int32_t pixel_count;     /* pixels labelled with this id */
  int32_t frames_tracked;  /* consecutive frames this id has been seen (1 = new) */
  float centroid[3];       /* mean 3D point of its pixels, metres */
  dp_joint joints[DP_JOINT_COUNT];
} dp_user;

typedef struct dp_floor {
  float nx, ny, nz, d; /* n·p + d = height of p above the floor (metres); n unit, pointing up */
  int32_t valid;       /* 1 when a floor plane is known this frame */
} dp_floor;

typedef struct dp_tracker dp_tracker; /* opaque */

uint32_t dp_api_version(void);
const char* dp_status_message(dp_status status);
/* "head", "neck", "shoulder_l", ... for 0..DP_JOINT_COUNT−1; "?" otherwise. */
const char* dp_joint_name(int32_t joint);

/* Bytes a tracker needs for this blob and frames up to max_width × max_height; 0 when the blob is
 * invalid or the sizes are outside 1..4096. */
size_t dp_tracker_memory_bytes(const void* blob, size_t blob_bytes, int32_t max_width, int32_t max_height);
/* Builds a tracker in `memory` (smoothing DP_SMOOTHING_DEFAULT). DP_OK and *out set, or an error
 * and *out = NULL (when out is not null). */
dp_status dp_tracker_open(const void* blob, size_t blob_bytes, int32_t max_width, int32_t max_height, void* memory,
                          size_t memory_bytes, dp_tracker** out);
/* The temporal filter of the joints (docs/skeleton.md). DP_ERROR_ARGUMENT for another value. */
dp_status dp_tracker_set_smoothing(dp_tracker* tracker, int32_t smoothing);
/* One depth frame (row-major, stride_px elements per row): finds the users, their joints, the floor.
 * On error the previous frame's results are cleared (no users). */
dp_status dp_tracker_process(dp_tracker* tracker, const uint16_t* depth_mm, int32_t width, int32_t height,
                             int32_t stride_px, const dp_intrinsics* intrinsics);
/* Users of the last processed frame (0 before any, or when closed). */
int32_t dp_tracker_user_count(const dp_tracker* tracker);
dp_status dp_tracker_get_user(const dp_tracker* tracker, int32_t index, dp_user* out);
/* The last frame's user map: one byte per pixel (0 = nobody, else the user id), `*stride` bytes per
 * row; valid until the next dp_tracker_process. NULL before any frame (the outputs are then 0). */
const uint8_t* dp_tracker_user_map(const dp_tracker* tracker, int32_t* width, int32_t* height, int32_t* stride);
dp_status dp_tracker_get_floor(const dp_tracker* tracker, dp_floor* out);
/* Invalidates the handle; the memory belongs to the caller again. Null is ignored. */
void dp_tracker_close(dp_tracker* tracker);

#ifdef __cplusplus
}
#endif
#endif /* DEPTHPOSE_C_H */
