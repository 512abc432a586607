// `depthpose run`: argument parsing around run_app (tools/app/run.h).
#include <csignal>
#include <cstdio>

#include "tools/app/app_common.h"
#include "tools/app/run.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/budget_options.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/kernel_option.h"

namespace dp::tools {

static void on_interrupt(int) { request_stop(); }

static int run_run(int argc, char** argv) {
  std::vector<std::string> options = kSourceOptionNames;
  options.insert(options.end(), {"--blob", "--source", "--overlay", "--every", "--frames", "--loop", "--kernel", "--segment", "--segment-config", "--smoothing",
                                    kBudgetOptionNames[0], kBudgetOptionNames[1]});
  Args args(argc, argv,
            std::string("usage: depthpose run --blob BLOB --source SRC [--json] [--overlay DIR] [--every N]\n"
                        "                     [--realtime] [--all-proposals] [--frames N] [--loop N] [--kernel K]\n"
                        "  Runs the forest on every frame of a source: one JSON line per frame on stdout (--json),\n"
                        "  events and a closing summary (fps, p50/p99/max frame time, budget overruns, dropped and\n"
                        "  corrupt frames) on stderr.\n"
                        "  --blob BLOB          the model (a forest blob, docs/blob_format.md)\n") +
                kSourceUsage +
                "  --json               one JSON line per processed frame (schema: docs/app.md); without it\n"
                "                       one text line per frame (best proposal per joint)\n"
                "  --quiet              no per-frame output, only events and the summary\n"
                "  --all-proposals      include every proposal of every joint, not only the best\n"
                "  --overlay DIR        write DIR/NNNNNN.png per processed frame: parts, joints, skeleton\n"
                "  --every N            process every N-th frame of the source (default 1)\n"
                "  --realtime           replay files at their recorded pace, dropping frames when late\n"
                "                       (live sources always deliver the newest frame)\n"
                "  --frames N           stop after N processed frames\n"
                "  --loop N             play a file source N times (rewound at its end): soak runs (docs/app.md)\n" +
                kKernelOptionUsage + kBudgetOptionsUsage +
                "  --segment MODE       on, off or auto (default): find the people first (floor, background model,\n"
                "                       users with stable ids; docs/segmentation.md) and report joints per user.\n"
                "                       auto = on for live sources and .oni files, off for raw files and datasets\n"
                "  --segment-config FILE  SegmenterConfig settings over the defaults: key = value lines (# comments)\n"
                "                       or a JSON object; an unknown key or a bad or out-of-range value is an error\n"
                "                       (keys, ranges: docs/segmentation.md)\n"
                "  --smoothing P        the skeleton's temporal filter: off, default or strong (docs/skeleton.md)\n"
                "  --no-usb-watch       live sources: do not watch the USB bus for the camera leaving/returning\n",
            options, {"--json", "--quiet", "--realtime", "--all-proposals", "--no-usb-watch"});
  if (args.help_requested()) {
    std::printf("%s", args.usage().c_str());
    return 0;
  }
  RunOptions o;
  o.blob_path = args.get("--blob");
  o.source_spec = args.get("--source");
  o.source_options = source_options_from(args);
  o.json = args.flag("--json");
  o.quiet = args.flag("--quiet");
  o.all_proposals = args.flag("--all-proposals");
  o.overlay_dir = args.get("--overlay", "");
  o.every = int(args.get_int("--every", 1));
  if (o.every < 1) fail("--every must be at least 1");
  o.realtime = args.flag("--realtime");
  o.max_frames = args.get_int("--frames", -1);
  if (args.has("--frames") && o.max_frames < 1) fail("--frames must be at least 1");
  o.loop = args.get_int("--loop", 1);
  if (o.loop < 1) fail("--loop must be at least 1");
  o.kernel = parse_kernel_option(args.get("--kernel", "best"));
  o.usb_watch = !args.flag("--no-usb-watch");
  o.budget = budget_overrides_from_args(args);
  const std::string segment = args.get("--segment", "auto");
  if (segment == "auto") o.segment = SegmentMode::kAuto;
  else if (segment == "on") o.segment = SegmentMode::kOn;
  else if (segment == "off") o.segment = SegmentMode::kOff;
  else fail("--segment wants on, off or auto, got '" + segment + "'");
  o.segment_config_path = args.get("--segment-config", "");
  const std::string smoothing = args.get("--smoothing", "default");
  if (smoothing == "off") o.smoothing = SkeletonFilterPreset::kOff;
  else if (smoothing == "default") o.smoothing = SkeletonFilterPreset::kDefault;
  else if (smoothing == "strong") o.smoothing = SkeletonFilterPreset::kStrong;
  else fail("--smoothing wants off, default or strong, got '" + smoothing + "'");
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  RunSummary s = run_app(o, stdout, stderr);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  check_output_stream();  // --json > /dev/full, a full disk: exit 1, not 0
  return s.source_failed ? 1 : 0;
}

DP_REGISTER_COMMAND(run, "run", "run a blob on a depth source (files, .oni, OpenNI2, V4L2)", run_run);

}  // namespace dp::tools
