/* Reads a blob, feeds depth frames, prints every user's joints (docs/skeleton.md, "C API"). */
#include <stdio.h>
#include <stdlib.h>
#include "runtime/depthpose_c.h"

int depthpose_example(const void* blob, size_t blob_bytes, const uint16_t* depth, int frames, int w, int h) {
  if (dp_api_version() != DP_API_VERSION) return 1;
  size_t bytes = dp_tracker_memory_bytes(blob, blob_bytes, w, h);
  void* memory = bytes ? aligned_alloc(DP_MEMORY_ALIGNMENT, (bytes + 63) / 64 * 64) : NULL;
  dp_tracker* tracker = NULL;
  dp_status s = memory ? dp_tracker_open(blob, blob_bytes, w, h, memory, bytes, &tracker) : DP_ERROR_ARGUMENT;
  if (s != DP_OK) { fprintf(stderr, "open: %s\n", dp_status_message(s)); free(memory); return 1; }
  const dp_intrinsics camera = {262.5f * w / 320, 262.5f * w / 320, (w - 1) / 2.0f, (h - 1) / 2.0f};
  for (int f = 0; f < frames && s == DP_OK; ++f) {
    s = dp_tracker_process(tracker, depth + (size_t)f * w * h, w, h, w, &camera);
    for (int i = 0; i < dp_tracker_user_count(tracker); ++i) {
      dp_user user;
      dp_tracker_get_user(tracker, i, &user);
      const dp_joint* head = &user.joints[0];
      printf("frame %d user %d: %s at (%.2f, %.2f, %.2f) m, confidence %.2f, state %d\n", f, user.id,
             dp_joint_name(0), head->x, head->y, head->z, head->confidence, head->state);
    }
  }
  dp_floor floor;
  if (s == DP_OK && dp_tracker_get_floor(tracker, &floor) == DP_OK && floor.valid)
    printf("camera %.2f m above the floor\n", floor.d);
  dp_tracker_close(tracker);
  free(memory);
  return s == DP_OK ? 0 : 1;
}
