// The C interface between the depthpose process and its own OpenNI2 driver
// (libdepthpose_feed.so.0, built from platform/openni_driver/ by mk/openni.mk).
//
// OpenNI2 loads the driver from <dir of libOpenNI2.so.0>/OpenNI2/Drivers/. The process dlopens the
// same file (same handle, same globals) and calls dp_feed_attach() to hand it a feed. Opening the
// device URI "depthpose-feed://<name>" through OpenNI2 then yields a one-sensor depth device whose
// stream calls feed->next_frame on the driver's own thread and raises each frame to OpenNI2 — so
// openni::Recorder can record any frame source, and tests can exercise the "live device" path.
//
// Threading: next_frame runs on the driver thread. It must return within ~100 ms (return
// kDpFeedAgain when nothing is ready) so that stopping the stream never waits long.
#pragma once
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define DP_FEED_ABI_VERSION 1
#define DP_FEED_URI_PREFIX "depthpose-feed://"
#define DP_FEED_ATTACH_SYMBOL "dp_feed_attach"

enum DpFeedResult {
  kDpFeedFrame = 1,   // `depth` filled, `timestamp_us` set
  kDpFeedAgain = 0,   // nothing yet, call again
  kDpFeedEnd = -1,    // no more frames: the driver stops producing (the device stays)
  kDpFeedLost = -2,   // the device is gone: the driver reports a disconnect and stops producing
};

typedef struct DpFeed {
  uint32_t abi_version;   // DP_FEED_ABI_VERSION
  const char* name;       // device URI is DP_FEED_URI_PREFIX + name
  int32_t width, height;  // depth frame size, pixels
  int32_t fps;            // nominal frame rate reported in the video mode
  float horizontal_fov_rad, vertical_fov_rad;  // reported as stream FOV (recorded in .oni)
  int32_t max_depth_mm;   // ONI_STREAM_PROPERTY_MAX_VALUE, ≥ the largest pixel served
  void* user;
  // Fills `depth` (width·height uint16 mm, row-major). Returns a DpFeedResult.
  int (*next_frame)(void* user, uint16_t* depth, uint64_t* timestamp_us);
  // Whether tryDevice should (re)connect the device now (a replugged camera). May be NULL = yes.
  int (*present)(void* user);
} DpFeed;

// Attaches (feed != NULL) or detaches (NULL) the feed. The DpFeed and its user data must stay
// valid until detached; detaching while a stream of the device is running is refused (returns
// -1). Returns 0 on success, -1 on a bad ABI version or a running stream.
typedef int (*DpFeedAttachFn)(const DpFeed* feed);

// Frames the driver raised to OpenNI2 since the feed was attached (for the recorder, which must
// know every frame was handed over before it stops).
typedef int64_t (*DpFeedServedFn)(void);
#define DP_FEED_SERVED_SYMBOL "dp_feed_frames_served"
// Whether the driver thread has finished (end, lost or stopped) since the stream last started.
typedef int (*DpFeedIdleFn)(void);
#define DP_FEED_IDLE_SYMBOL "dp_feed_idle"

#ifdef __cplusplus
}
#endif
