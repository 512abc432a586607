// `depthpose record`: any source into an .oni file through depthpose's own OpenNI2 driver, then a
// pixel-for-pixel check of the recording.
#include <cstdio>

#include "platform/oni_recorder.h"
#include "tools/app/app_common.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"

namespace dp::tools {

static int run_record(int argc, char** argv) {
  std::vector<std::string> options = kSourceOptionNames;
  options.insert(options.end(), {"--source", "--out", "--frames", "--fps", "--subsample"});
  Args args(argc, argv,
            std::string("usage: depthpose record --source SRC --out FILE.oni [--frames N] [--subsample K] [--zero-border]\n"
                        "  Records depth frames into an OpenNI2 recording (through depthpose's own OpenNI2\n"
                        "  driver and openni::Recorder), then replays it and checks every frame pixel for pixel.\n") +
                kSourceUsage +
                "  --out FILE.oni       the recording to write (overwritten)\n"
                "  --frames N           record at most N frames (default: until the source ends)\n"
                "  --fps N              nominal frame rate written into the file (default 30)\n"
                "  --subsample K        keep every K-th pixel of every K-th row (1..16; e.g. 4: 320x240 -> 80x60),\n"
                "                       for small, fast recordings such as the soak's (docs/app.md)\n"
                "  --zero-border        blank the outermost pixel ring (avoids a rare OpenNI2 16zT codec fault)\n",
            options, {"--zero-border"});
  if (args.help_requested()) {
    std::printf("%s", args.usage().c_str());
    return 0;
  }
  const std::string spec = args.get("--source");
  const std::string out = args.get("--out");
  platform::SourceOptions source_options = source_options_from(args);
  platform::RecordOptions o;
  o.max_frames = args.get_int("--frames", -1);
  if (args.has("--frames") && o.max_frames < 1) fail("--frames must be at least 1");
  o.fps = int(args.get_int("--fps", 30));
  if (o.fps < 1 || o.fps > 1000) fail("--fps must be within 1..1000");
  o.zero_border = args.flag("--zero-border");
  const int subsample = int(args.get_int("--subsample", 1));
  if (subsample < 1 || subsample > platform::kMaxSubsample)
    fail("--subsample must be within 1.." + std::to_string(platform::kMaxSubsample));
  const bool replayable = source_is_replayable(spec);
  // A live source is opened once; the recorder asks for it only once then.
  auto reopen = [&]() { return platform::subsample_source(platform::open_source(spec, source_options), subsample); };
  platform::RecordReport r = platform::record_oni(reopen, replayable, out, o);
  std::printf("recorded %lld frames (%dx%d) to %s; verified %lld frames %s%s\n", (long long)r.frames_recorded, r.width,
              r.height, out.c_str(), (long long)r.frames_verified,
              r.verified_by_pixels ? "pixel for pixel against the source" : "by CRC-32 of each served frame",
              r.corrupt_skipped ? (", " + std::to_string(r.corrupt_skipped) + " corrupt source frame(s) skipped").c_str() : "");
  if (r.attempts > 1) std::printf("(OpenNI2's recorder dropped early frames; recorded %d times)\n", r.attempts);
  return 0;
}

DP_REGISTER_COMMAND(record, "record", "record any depth source into a verified .oni file", run_record);

}  // namespace dp::tools
