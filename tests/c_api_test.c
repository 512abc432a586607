/* The C API (runtime/depthpose_c.h) exercised from C: compiled as C11 by gcc and run from
 * tests/c_api_runner_test.cc on frames of models/demo.oni. Each check that fails writes what it
 * expected into `message` and returns its line number (0 = every check held). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runtime/depthpose_c.h"

#define CHECK(condition, ...)                                  \
  do {                                                         \
    if (!(condition)) {                                        \
      snprintf(message, message_bytes, __VA_ARGS__);          \
      free(raw);                                               \
      return __LINE__;                                         \
    }                                                          \
  } while (0)

int dp_c_api_selftest(const void* blob, size_t blob_bytes, const uint16_t* depth, int frames, int w, int h,
                      char* message, size_t message_bytes) {
  void* raw = NULL;
  CHECK(dp_api_version() == DP_API_VERSION, "dp_api_version() %u, header %d", dp_api_version(), DP_API_VERSION);
  CHECK(strcmp(dp_joint_name(2), "shoulder_l") == 0 && strcmp(dp_joint_name(16), "?") == 0, "joint names");
  CHECK(strcmp(dp_status_message(DP_ERROR_BLOB), "ok") != 0, "status messages");

  const size_t bytes = dp_tracker_memory_bytes(blob, blob_bytes, w, h);
  CHECK(bytes > 0, "dp_tracker_memory_bytes of a valid blob is 0");
  CHECK(dp_tracker_memory_bytes(NULL, blob_bytes, w, h) == 0, "a null blob has a size");
  CHECK(dp_tracker_memory_bytes(blob, blob_bytes, 0, h) == 0, "a zero width has a size");
  raw = malloc(bytes + 2 * DP_MEMORY_ALIGNMENT);
  CHECK(raw != NULL, "out of memory");
  uint8_t* memory = (uint8_t*)(((uintptr_t)raw + DP_MEMORY_ALIGNMENT - 1) / DP_MEMORY_ALIGNMENT * DP_MEMORY_ALIGNMENT);
  dp_tracker* t = (dp_tracker*)1;
  CHECK(dp_tracker_open(blob, blob_bytes, w, h, memory + 8, bytes, &t) == DP_ERROR_MEMORY_MISALIGNED && t == NULL,
        "misaligned memory accepted");
  CHECK(dp_tracker_open(blob, blob_bytes, w, h, memory, bytes - 1, &t) == DP_ERROR_MEMORY_TOO_SMALL, "small memory accepted");
  CHECK(dp_tracker_open(blob, blob_bytes, w, h, memory, bytes, NULL) == DP_ERROR_ARGUMENT, "null out accepted");
  static uint64_t garbage[64];
  CHECK(dp_tracker_open(garbage, sizeof garbage, w, h, memory, bytes, &t) == DP_ERROR_BLOB, "garbage blob accepted");
  CHECK(dp_tracker_process(NULL, depth, w, h, w, NULL) == DP_ERROR_NOT_OPEN, "process on a null handle");

  CHECK(dp_tracker_open(blob, blob_bytes, w, h, memory, bytes, &t) == DP_OK && t != NULL, "open failed");
  CHECK(dp_tracker_user_map(t, NULL, NULL, NULL) == NULL, "a user map before any frame");
  const dp_intrinsics camera = {262.5f * (float)w / 320.0f, 262.5f * (float)w / 320.0f, (float)(w - 1) / 2.0f,
                                (float)(h - 1) / 2.0f};
  CHECK(dp_tracker_process(t, depth, w, h, w - 1, &camera) == DP_ERROR_ARGUMENT, "stride < width accepted");
  CHECK(dp_tracker_process(t, depth, w + 1, h, w + 1, &camera) == DP_ERROR_FRAME_TOO_LARGE, "large frame accepted");
  CHECK(dp_tracker_process(t, depth, w, h, w, NULL) == DP_ERROR_ARGUMENT, "null intrinsics accepted");
  CHECK(dp_tracker_set_smoothing(t, 3) == DP_ERROR_ARGUMENT, "smoothing 3 accepted");
  CHECK(dp_tracker_set_smoothing(t, DP_SMOOTHING_STRONG) == DP_OK, "smoothing strong refused");

  int users_seen = 0, tracked = 0;
  for (int f = 0; f < frames; ++f) {
    const uint16_t* frame = depth + (size_t)f * (size_t)w * (size_t)h;
    dp_status s = dp_tracker_process(t, frame, w, h, w, &camera);
    CHECK(s == DP_OK, "frame %d: %s", f, dp_status_message(s));
    int32_t mw = 0, mh = 0, stride = 0;
    const uint8_t* map = dp_tracker_user_map(t, &mw, &mh, &stride);
    CHECK(map != NULL && mw == w && mh == h && stride == w, "frame %d: user map %dx%d stride %d", f, mw, mh, stride);
    const int32_t n = dp_tracker_user_count(t);
    CHECK(n >= 0 && n <= DP_MAX_USERS, "frame %d: %d users", f, n);
    users_seen += n;
    for (int i = 0; i < n; ++i) {
      dp_user u;
      CHECK(dp_tracker_get_user(t, i, &u) == DP_OK, "get_user %d", i);
      CHECK(u.id >= 1 && u.id <= DP_MAX_USERS, "user id %d", u.id);
      long pixels = 0;
      for (int p = 0; p < w * h; ++p) pixels += map[p] == u.id;
      CHECK(pixels == u.pixel_count, "user %d: %ld pixels in the map, %d reported", u.id, pixels, u.pixel_count);
      for (int j = 0; j < DP_JOINT_COUNT; ++j) {
        const dp_joint* jt = &u.joints[j];
        CHECK(jt->confidence >= 0.0f && jt->confidence <= 1.0f, "%s confidence %f", dp_joint_name(j), jt->confidence);
        CHECK(jt->state >= DP_JOINT_MISSING && jt->state <= DP_JOINT_TRACKED, "%s state %d", dp_joint_name(j), jt->state);
        if (jt->orientation_valid) {
          const float* q = jt->orientation;
          CHECK(fabsf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0f) < 1e-4f, "%s orientation not unit",
                dp_joint_name(j));
        }
        CHECK(!(j == 1 && jt->orientation_valid), "the neck has no bone orientation");
        if (jt->state == DP_JOINT_MISSING) continue;
        tracked += jt->state == DP_JOINT_TRACKED;
        CHECK(jt->z > 0.3f && jt->z < 9.0f, "%s of user %d at z %f m", dp_joint_name(j), u.id, jt->z);
        CHECK(fabsf(jt->x - u.centroid[0]) < 1.5f && fabsf(jt->z - u.centroid[2]) < 1.5f,
              "%s of user %d is %f m from its centroid", dp_joint_name(j), u.id, fabsf(jt->x - u.centroid[0]));
      }
    }
    dp_user none;
    CHECK(dp_tracker_get_user(t, n, &none) == DP_ERROR_INDEX, "user index %d accepted", n);
  }
  CHECK(users_seen > 0, "no user in %d frames", frames);
  CHECK(tracked > 0, "no tracked joint in %d frames", frames);
  dp_floor floor;
  CHECK(dp_tracker_get_floor(t, &floor) == DP_OK, "get_floor");
  if (floor.valid)
    CHECK(fabsf(floor.nx * floor.nx + floor.ny * floor.ny + floor.nz * floor.nz - 1.0f) < 1e-3f, "floor normal not unit");
  dp_tracker_close(t);
  CHECK(dp_tracker_user_count(t) == 0, "users after close");
  CHECK(dp_tracker_process(t, depth, w, h, w, &camera) == DP_ERROR_NOT_OPEN, "process after close");
  free(raw);
  return 0;
}
