// `depthpose side-check`: runs the app's pipeline (segmentation, forest, skeleton tracker) on each
// frame a side-truth file marks, as a still (a fresh pipeline per frame, no smoothing: the frames
// are unrelated), and prints per frame whether every marked person's left and right arm joints
// landed on their own side (tools/eval/side_check.h). docs/results.md quotes its table.
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "tools/app/run.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/eval/side_check.h"

namespace dp::tools {
namespace {

const char* kSideCheckUsage =
    "usage: depthpose side-check --blob BLOB --truth FILE --frames DIR [--json OUT] [--segment on|off]\n"
    "  For each frame of the truth file (marked shoulders, elbows and hands of front-facing people;\n"
    "  format in tools/eval/side_check.h), runs the pipeline and the skeleton tracker on DIR/FILE as a\n"
    "  still and reports, per marked person, which left/right joints are on their own side, swapped\n"
    "  or missing, and the frames where every marked joint is on its side.\n"
    "  --truth FILE      e.g. docs/data/skeltrack_sides.json\n"
    "  --frames DIR      the raw frames (16-bit little-endian millimetres, the truth's size)\n"
    "  --json OUT        the verdicts as JSON\n"
    "  --segment MODE    on (default: one skeleton per person found) or off (one skeleton per frame)\n";

std::optional<std::array<double, 3>> joint_xyz(const nlohmann::json& joints, const std::string& name) {
  for (const auto& j : joints)
    if (j.at("name") == name) {
      if (!j.at("x").is_number() || j.value("state", "") == "missing") return std::nullopt;
      return std::array<double, 3>{j.at("x").get<double>(), j.at("y").get<double>(), j.at("z").get<double>()};
    }
  fail("side-check: the pipeline reported no joint named " + name + " (is the blob a 16-joint model?)");
}

ReportedSkeleton skeleton_from(const nlohmann::json& joints) {
  ReportedSkeleton s;
  s.head = joint_xyz(joints, "head");
  for (size_t k = 0; k < kSideJoints.size(); ++k) {
    s.left[k] = joint_xyz(joints, std::string(kSideJoints[k]) + "_l");
    s.right[k] = joint_xyz(joints, std::string(kSideJoints[k]) + "_r");
  }
  return s;
}

const char* outcome_text(SideOutcome o) {
  return o == SideOutcome::kCorrect ? "ok" : o == SideOutcome::kSwapped ? "SWAPPED" : "missing";
}

int side_check_main(int argc, char** argv) {
  Args args(argc, argv, kSideCheckUsage, {"--blob", "--truth", "--frames", "--json", "--segment"});
  if (args.help_requested()) {
    std::printf("%s", kSideCheckUsage);
    return 0;
  }
  const SideTruth truth = load_side_truth(args.get("--truth"));
  const std::string dir = args.get("--frames");
  const std::string segment = args.get("--segment", "on");
  if (segment != "on" && segment != "off") fail("--segment must be on or off, got '" + segment + "'");

  RunOptions run;
  run.blob_path = args.get("--blob");
  run.json = true;
  run.smoothing = SkeletonFilterPreset::kOff;
  run.segment = segment == "on" ? SegmentMode::kOn : SegmentMode::kOff;
  run.usb_watch = false;
  run.source_options.has_intrinsics = true;
  run.source_options.intrinsics = {static_cast<float>(truth.fx), static_cast<float>(truth.fy),
                                   static_cast<float>(truth.cx), static_cast<float>(truth.cy)};

  nlohmann::json report = nlohmann::json::array();
  int frames_correct = 0, swapped_total = 0, missing_total = 0, marked_total = 0;
  std::printf("| frame | file | people found / marked | joints on their side | swapped | missing | all sides right |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (size_t f = 0; f < truth.frames.size(); ++f) {
    const SideTruthFrame& tf = truth.frames[f];
    run.source_spec = "raw:" + dir + "/" + tf.file + ":" + std::to_string(truth.width) + "x" + std::to_string(truth.height);
    char* text = nullptr;
    size_t size = 0;
    FILE* out = open_memstream(&text, &size);
    if (out == nullptr) fail("side-check: cannot open a memory stream");
    FILE* log = std::fopen("/dev/null", "w");
    RunSummary summary;
    try {
      summary = run_app(run, out, log != nullptr ? log : stderr);
    } catch (...) {
      std::fclose(out);
      std::free(text);
      if (log != nullptr) std::fclose(log);
      throw;
    }
    std::fclose(out);
    if (log != nullptr) std::fclose(log);
    const std::string lines(text, size);
    std::free(text);
    if (summary.source_failed || summary.frames_processed != 1)
      fail("side-check: " + run.source_spec + ": the pipeline processed " + std::to_string(summary.frames_processed) +
           " frames" + (summary.source_error.empty() ? "" : " (" + summary.source_error + ")"));
    const nlohmann::json line = nlohmann::json::parse(lines.substr(0, lines.find('\n')));
    std::vector<ReportedSkeleton> skeletons;
    if (line.contains("users"))
      for (const auto& u : line.at("users")) skeletons.push_back(skeleton_from(u.at("joints")));
    else
      skeletons.push_back(skeleton_from(line.at("joints")));

    const FrameVerdict v = judge_sides(truth, tf, skeletons);
    int correct = 0, matched = 0, marked = 0;
    nlohmann::json people = nlohmann::json::array();
    for (size_t p = 0; p < v.people.size(); ++p) {
      const PersonVerdict& pv = v.people[p];
      correct += pv.correct;
      matched += pv.skeleton >= 0 ? 1 : 0;
      nlohmann::json joints = nlohmann::json::object();
      for (size_t k = 0; k < kSideJoints.size(); ++k)
        if (tf.people[p].left[k]) {
          marked += 2;
          joints[std::string(kSideJoints[k]) + "_l"] = outcome_text(pv.left[k]);
          joints[std::string(kSideJoints[k]) + "_r"] = outcome_text(pv.right[k]);
        }
      people.push_back({{"matched", pv.skeleton >= 0}, {"joints", joints}});
    }
    frames_correct += v.sides_correct ? 1 : 0;
    swapped_total += v.swapped;
    missing_total += v.missing;
    marked_total += marked;
    std::printf("| %zu | %s | %d / %zu | %d / %d | %d | %d | %s |\n", f, tf.file.c_str(), matched, tf.people.size(),
                correct, marked, v.swapped, v.missing, v.sides_correct ? "yes" : "**no**");
    report.push_back({{"file", tf.file},
                      {"people_found", static_cast<int>(skeletons.size())},
                      {"sides_correct", v.sides_correct},
                      {"swapped", v.swapped},
                      {"missing", v.missing},
                      {"people", people}});
  }
  std::printf("\nframes with every marked joint on its own side: %d of %zu (marked joints %d: swapped %d, missing %d)\n",
              frames_correct, truth.frames.size(), marked_total, swapped_total, missing_total);
  if (args.has("--json")) {
    nlohmann::json doc = {{"blob", run.blob_path},
                          {"truth", args.get("--truth")},
                          {"frames_correct", frames_correct},
                          {"frames", static_cast<int>(truth.frames.size())},
                          {"swapped", swapped_total},
                          {"missing", missing_total},
                          {"per_frame", report}};
    write_file_atomic(args.get("--json"), doc.dump(2) + "\n");
  }
  return 0;
}

}  // namespace
}  // namespace dp::tools

DP_REGISTER_COMMAND(side_check, "side-check",
                    "left/right check of the skeleton on real frames with marked arms (Skeltrack)",
                    dp::tools::side_check_main);
