// `depthpose skeleton-eval`: argument parsing and the report of evaluate_skeletons
// (tools/app/skeleton_eval.h), as Markdown tables that docs/skeleton.md quotes.
#include <cmath>
#include <cstdio>

#include "tools/app/skeleton_eval.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"

namespace dp::tools {
namespace {

const char* kUsage =
    "usage: depthpose skeleton-eval --blob BLOB --data DIR[,DIR...] [--frames N] [--filter-sweep]\n"
    "                               [--fit-calibration] [--swap-causes]\n"
    "  Runs the pipeline and the skeleton tracker over synthetic sequences (depthpose synth --sequence,\n"
    "  one or more --people; each body cut out by its ground-truth mask) and prints, as Markdown:\n"
    "  per joint the within-0.1 m rate of the first proposal and of the tracker's joint, left/right\n"
    "  swaps per 1000 left/right joint-frames (also apart for the joints visible in the frame and the\n"
    "  hidden ones), 95 % intervals of the tracker's gain and swap change from resampling whole\n"
    "  sequences, the confidence's reliability diagram, jitter of still joints and lag on fast motion\n"
    "  for the filter presets, and the tracker's cost (docs/skeleton.md).\n"
    "  --frames N          at most N frames of each sequence\n"
    "  --filter-sweep      also measure a grid of 1€ settings (min cutoff × beta)\n"
    "  --fit-calibration   print the calibration table fitted on these sequences (isotonic over the\n"
    "                      tracked classes), to paste into runtime/skeleton_tracker.cc as the\n"
    "                      table of the blob's forest method (BPC or OJR)\n"
    "  --swap-causes       per left/right joint, the tracker's swaps by what it chose (its own first\n"
    "                      proposal, another own proposal, the mirror joint's, its last position), and\n"
    "                      how many of them had the torso's facing crossed, the parent joint swapped,\n"
    "                      the joint and its mirror in reverse order across the body, the first\n"
    "                      proposal right\n";

void print_filter_row(const FilterFigures& f, const char* name) {
  if (f.params.enabled)
    std::printf("| %s | %.2f | %.2f | %.2f | %.1f | %.2f | %.3f |\n", name, f.params.min_cutoff_hz, f.params.beta,
                f.params.d_cutoff_hz, f.jitter_mm, f.lag_frames, f.within_rate);
  else
    std::printf("| %s | – | – | – | %.1f | %.2f | %.3f |\n", name, f.jitter_mm, f.lag_frames, f.within_rate);
}

int skeleton_eval_main(int argc, char** argv) {
  Args args(argc, argv, kUsage, {"--blob", "--data", "--frames"}, {"--filter-sweep", "--fit-calibration", "--swap-causes"});
  if (args.help_requested()) {
    std::printf("%s", kUsage);
    return 0;
  }
  SkeletonEvalOptions o;
  o.blob_path = args.get("--blob");
  o.datasets = split_list(args.get("--data"));
  o.max_frames = int(args.get_int("--frames", -1));
  if (args.has("--frames") && o.max_frames < 1) fail("--frames must be at least 1");
  if (args.flag("--filter-sweep"))
    for (float cutoff : {0.5f, 1.0f, 1.5f, 2.5f, 4.0f})
      for (float beta : {0.5f, 2.0f, 8.0f}) o.sweep.push_back({1, cutoff, beta, 1.0f});
  const SkeletonEvalReport r = evaluate_skeletons(o);

  std::printf("%ld frames, %ld body-frames scored (%zu sequences)\n\n", r.frames, r.body_frames, o.datasets.size());
  std::printf("| joint | first proposal within 0.1 m | tracker within 0.1 m | swaps ‰ first proposal | swaps ‰ tracker |\n"
              "|---|---|---|---|---|\n");
  long p_all = 0, t_all = 0, n_all = 0;
  for (int j = 0; j < kSkeletonJoints; ++j) {
    const double n = double(std::max(1L, r.joint_frames[size_t(j)]));
    std::printf("| %s | %.3f | %.3f ", skeleton_joint_name(j), double(r.proposal_hits[size_t(j)]) / n,
                double(r.tracker_hits[size_t(j)]) / n);
    if (j >= kShoulderL)
      std::printf("| %.1f | %.1f |\n", 1000.0 * double(r.proposal_swaps_by_joint[size_t(j)]) / n,
                  1000.0 * double(r.tracker_swaps_by_joint[size_t(j)]) / n);
    else
      std::printf("| – | – |\n");
    p_all += r.proposal_hits[size_t(j)];
    t_all += r.tracker_hits[size_t(j)];
    n_all += r.joint_frames[size_t(j)];
  }
  std::printf("| **all** | **%.3f** | **%.3f** | | |\n\n", double(p_all) / double(std::max(1L, n_all)),
              double(t_all) / double(std::max(1L, n_all)));
  const double lr = double(std::max(1L, r.lr_joint_frames));
  std::printf("left/right swaps per 1000 left/right joint-frames: first proposal %.1f, tracker %.1f (%ld joint-frames)\n\n",
              1000.0 * double(r.proposal_swaps) / lr, 1000.0 * double(r.tracker_swaps) / lr, r.lr_joint_frames);
  const long hidden = r.lr_joint_frames - r.lr_visible_joint_frames;
  std::printf("of them, joints visible in the frame: first proposal %.1f, tracker %.1f (%ld joint-frames); hidden or out of\n"
              "view: first proposal %.1f, tracker %.1f (%ld joint-frames)\n\n",
              1000.0 * double(r.proposal_swaps_visible) / double(std::max(1L, r.lr_visible_joint_frames)),
              1000.0 * double(r.tracker_swaps_visible) / double(std::max(1L, r.lr_visible_joint_frames)), r.lr_visible_joint_frames,
              1000.0 * double(r.proposal_swaps - r.proposal_swaps_visible) / double(std::max(1L, hidden)),
              1000.0 * double(r.tracker_swaps - r.tracker_swaps_visible) / double(std::max(1L, hidden)), hidden);
  const SequenceIntervals iv = sequence_intervals(r.sequences);
  std::printf("over the %zu sequences, with 95 %% intervals from %d resamples of whole sequences: tracker − first\n"
              "proposal within 0.1 m %+.3f (%+.3f … %+.3f); swap change %+.1f %% (%+.1f … %+.1f %%)\n\n",
              r.sequences.size(), kIntervalResamples, iv.gain, iv.gain_low, iv.gain_high, 100.0 * iv.swap_change, 100.0 * iv.swap_change_low,
              100.0 * iv.swap_change_high);
  if (args.flag("--swap-causes")) {
    std::printf("Tracker swaps per 1000 joint-frames by the choice (default filter); then, of those swaps, per 1000\n"
                "joint-frames: torso facing crossed (tracker shoulders' facing against the truth's), parent swapped,\n"
                "joint and mirror in reverse order across the body, first proposal within 0.1 m.\n\n"
                "| joint | swaps ‰ | own first | own other | mirror's | last position | facing crossed | parent swapped "
                "| pair crossed | first right |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (int j = kShoulderL; j < kSkeletonJoints; ++j) {
      const double n = double(std::max(1L, r.joint_frames[size_t(j)])) / 1000.0;
      const auto& c = r.tracker_swap_choice[size_t(j)];  // by SwapChoice
      std::printf("| %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", skeleton_joint_name(j),
                  double(r.tracker_swaps_by_joint[size_t(j)]) / n, double(c[0]) / n, double(c[1]) / n, double(c[2]) / n,
                  double(c[3]) / n, double(r.tracker_swap_facing_flipped[size_t(j)]) / n,
                  double(r.tracker_swap_parent_swapped[size_t(j)]) / n, double(r.tracker_swap_pair_crossed[size_t(j)]) / n,
                  double(r.tracker_swap_first_right[size_t(j)]) / n);
    }
    std::printf("\n");
  }
  std::printf("off by > 0.1 m and nearer the mirror joint's truth, per 1000: first proposal %.1f, tracker %.1f\n\n",
              1000.0 * double(r.proposal_nearer_mirror) / lr, 1000.0 * double(r.tracker_nearer_mirror) / lr);
  const long states = r.state_count[0] + r.state_count[1] + r.state_count[2];
  std::printf("states: tracked %.3f, inferred %.3f, missing %.3f\n\n", double(r.state_count[2]) / double(std::max(1L, states)),
              double(r.state_count[1]) / double(std::max(1L, states)), double(r.state_count[0]) / double(std::max(1L, states)));
  std::printf("Reliability (default filter): confidence bin, joints, mean confidence, fraction within 0.1 m\n\n");
  std::printf("| bin | joints | mean confidence | within 0.1 m |\n|---|---|---|---|\n");
  double ece = 0;
  long located = 0;
  for (int b = 0; b < 10; ++b) located += r.bin_count[size_t(b)];
  for (int b = 0; b < 10; ++b) {
    if (!r.bin_count[size_t(b)]) continue;
    const double n = double(r.bin_count[size_t(b)]);
    const double conf = r.bin_confidence_sum[size_t(b)] / n, hit = double(r.bin_hits[size_t(b)]) / n;
    ece += n / double(std::max(1L, located)) * std::fabs(conf - hit);
    std::printf("| %.1f–%.1f | %ld | %.3f | %.3f |\n", b / 10.0, (b + 1) / 10.0, r.bin_count[size_t(b)], conf, hit);
  }
  std::printf("\nexpected calibration error: %.3f\n\n", ece);
  if (args.flag("--fit-calibration")) {
    // Per class hit rate (0 for a class no joint fell in), made monotone over the tracked classes
    // 0..9 by pool adjacent violators weighted by the joints per class; the inferred classes
    // 10..15 keep their own rates.
    std::array<double, kEvidenceClasses> rate{}, weight{};
    for (int c = 0; c < kEvidenceClasses; ++c) {
      long n = r.class_count[size_t(c)], h = r.class_hits[size_t(c)];
      rate[size_t(c)] = n ? double(h) / double(n) : 0.0;
      weight[size_t(c)] = double(n);
    }
    std::vector<std::array<double, 3>> blocks;  // value, weight, classes
    for (int c = 0; c < 10; ++c) {
      blocks.push_back({rate[size_t(c)], weight[size_t(c)], 1});
      while (blocks.size() > 1 && blocks[blocks.size() - 2][0] > blocks.back()[0]) {
        auto last = blocks.back();
        blocks.pop_back();
        auto& prev = blocks.back();
        const double wsum = prev[1] + last[1];
        prev[0] = wsum > 0 ? (prev[0] * prev[1] + last[0] * last[1]) / wsum : prev[0];
        prev[1] = wsum;
        prev[2] += last[2];
      }
    }
    int c = 0;
    for (const auto& blk : blocks)
      for (int k = 0; k < int(blk[2]); ++k) rate[size_t(c++)] = blk[0];
    std::printf("fitted calibration (class: joints, within 0.1 m, value):\n");
    for (int k = 0; k < kEvidenceClasses; ++k)
      std::printf("  %2d: %6ld %6ld  %.2f\n", k, r.class_count[size_t(k)], r.class_hits[size_t(k)], rate[size_t(k)]);
    std::printf("  {");
    for (int k = 0; k < kEvidenceClasses; ++k) std::printf("%s%.2ff", k ? ", " : "", rate[size_t(k)]);
    std::printf("}\n\n");
  }
  std::printf("Temporal filter: jitter = RMS frame-to-frame motion (mm) of joints whose truth moved < 5 mm;\n"
              "lag = frames behind the truth on joints moving > 1.5 m/s; within = all joints within 0.1 m.\n\n");
  std::printf("| filter | min cutoff Hz | beta | d cutoff Hz | jitter mm | lag frames | within 0.1 m |\n"
              "|---|---|---|---|---|---|---|\n");
  const char* names[] = {"off", "default", "strong"};
  for (size_t f = 0; f < r.filters.size(); ++f) print_filter_row(r.filters[f], f < 3 ? names[f] : "sweep");
  std::printf("\n(%ld still samples, %ld fast samples per filter)\n\n", r.filters[0].still_samples, r.filters[0].fast_samples);
  std::printf("cost per user and frame: tracker %.0f ticks, pipeline (forest, votes, mean shift) %.0f ticks\n",
              r.tracker_cycles_per_user_frame, r.pipeline_cycles_per_user_frame);
  return 0;
}

}  // namespace
}  // namespace dp::tools

DP_REGISTER_COMMAND(skeleton_eval, "skeleton-eval",
                    "measure the skeleton tracker on synthetic sequences (accuracy, swaps, calibration, filter)",
                    dp::tools::skeleton_eval_main);
