// `depthpose train`: command-line front end of forest_trainer.h. docs/training.md is the manual.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <thread>

#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/train/communicator.h"
#include "tools/train/forest_trainer.h"
#include "tools/train/forest_merge.h"
#include "tools/train/forest_truncate.h"

namespace dp::train {
namespace {

const std::string kUsage = std::string() +
    "usage: depthpose train --data DIR[,DIR...] --method bpc|ojr --out FILE.forest [options]\n"
    "       depthpose train --merge A.forest,B.forest[,...] --out FILE.forest\n"
    "  --trees T              trees (default 3)\n"
    "  --depth D              maximum depth, leaves at level <= D (default 20)\n"
    "  --objective O          classification (Eq. 8, default) or regression (Eq. 9-11)\n"
    "  --pixels-per-image N   training pixels per image, N_ex (default 2000)\n"
    "  --images-per-tree N    random images per tree (default 0 = all images)\n"
    "  --offsets N            candidate offset pairs per node (default 2000)\n"
    "  --thresholds N         candidate thresholds per offset pair, 1..255 (default 50)\n"
    "  --max-offset M         max |du|,|dv| in pixel*metres at the reference focal length\n"
    "                         (default round(129 * f_ref / 525): the paper's 129 at 640x480 Kinect, f = 525)\n"
    "  --reference-focal F    focal length (px) the offsets are expressed for (default fx of the first dataset)\n"
    "  --min-samples N        nodes with fewer pixels become leaves (default 10)\n"
    "  --rho R                regression: offsets longer than R metres are ignored (default 0.5)\n"
    "  --nres N               OJR reservoir capacity per leaf and joint (default 100)\n"
    "  --bandwidth B          OJR mean-shift bandwidth b*, metres (default 0.05)\n"
    "  --votes-per-leaf K     OJR votes kept per leaf and joint (default 2)\n"
    "  --vote-length L[,..]   OJR max vote length lambda_j, metres: one value or one per joint (default 0.5)\n"
    "  --structure FILE       retro-fit leaves onto this forest's trees instead of growing new ones\n"
    "  --structure-min-pixels N  first collapse every --structure subtree with fewer than N training pixels\n"
    "                         into a leaf (smaller OJR leaf tables, depth kept where the data is dense;\n"
    "                         docs/convert.md \"Pruning to a size budget\")\n"
    "  --structure-max-leaves N  or prune the --structure forest to N leaves over all trees, the splits of\n"
    "                         least information gain first (needs part distributions: a BPC forest)\n"
    "  --structure-depth D    cut the --structure trees back to depth D first (smaller OJR leaf tables)\n"
    "  --proposal FILE        mixture proposal: offsets drawn near FILE's chosen ones (90%) or uniform (10%)\n"
    "  --seed S               random seed (default 1); the forest is the same for any --threads\n"
    "  --threads N            worker threads (default: all cores)\n"
    "  --checkpoint FILE      checkpoint written after every level (with --structure: every minute and\n"
    "                         after every tree) (default: --out FILE + .checkpoint; removed once the\n"
    "                         forest is written)\n"
    "  --resume               continue from the checkpoint (same options and data; none = start over)\n"
    "  --stop-after L         stop with exit status 75 once this run has written L checkpoints (levels\n"
    "                         over all trees); --resume continues (e.g. within a batch system's time limit)\n"
    "  --quiet                no progress on stderr\n"
    "  --no-timings           leave the timings out of the file, so that runs compare byte for byte\n"
    "  --node-parallel-below N  distributed: nodes with fewer than N pixels are searched by one rank\n"
    "                         each from their pixels' features instead of by summing histograms over\n"
    "                         the ranks (default " + std::to_string(kDefaultNodeParallelPixels) + ", 0 = never); the same forest\n"
    "                         either way (docs/training.md \"What is communicated per level\")\n"
    "  --distributed          run as one rank of an MPI job even when no launcher is detected\n"
    "                         (mpirun/srun are detected; docs/training.md \"Distributed training\")\n"
    "  --merge A,B[,...]      write one forest of the trees of A, B, ...: runs trained on the same data with\n"
    "                         the same options but other --seed (refused otherwise, naming what differs);\n"
    "                         trees can so be trained one run at a time (docs/training.md \"Merging runs\")\n";

std::string format_duration(double s) {
  char b[32];
  if (s < 60)
    std::snprintf(b, sizeof b, "%.1fs", s);
  else if (s < 3600)
    std::snprintf(b, sizeof b, "%dm%02ds", int(s) / 60, int(s) % 60);
  else
    std::snprintf(b, sizeof b, "%dh%02dm", int(s) / 3600, int(s) % 3600 / 60);
  return b;
}

// Distributed runs: every rank must train with the same options (else their collective calls would
// not match). Rank 0 gathers each rank's options — the command line without --threads/--quiet
// (which may differ per machine) and, with --resume, a digest of the checkpoint that rank sees —
// and ends the job naming the first rank and option that differ.
void check_same_options(int argc, char** argv, const std::string& checkpoint_path, bool resume, Communicator& comm) {
  std::vector<std::string> mine;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quiet" || a == "--distributed") continue;
    if (a == "--threads") {
      ++i;
      continue;
    }
    mine.push_back(a);
  }
  if (resume) {
    std::ifstream f(checkpoint_path, std::ios::binary);
    uint64_t h = 0xCBF29CE484222325ull;
    char c;
    size_t bytes = 0;
    while (f.get(c)) {
      h = (h ^ uint8_t(c)) * 0x100000001B3ull;
      ++bytes;
    }
    char b[64];
    std::snprintf(b, sizeof b, "%016llx (%zu bytes)", static_cast<unsigned long long>(h), bytes);
    mine.push_back("checkpoint " + checkpoint_path + ": " + (bytes ? std::string(b) : std::string("none")));
  }
  std::vector<uint8_t> message;
  for (const std::string& a : mine) {
    message.insert(message.end(), a.begin(), a.end());
    message.push_back(0);
  }
  const std::vector<std::vector<uint8_t>> all = comm.gather(message);
  if (comm.rank() != 0) return;
  auto split = [](const std::vector<uint8_t>& m) {
    std::vector<std::string> out;
    std::string cur;
    for (uint8_t c : m) {
      if (c == 0) {
        out.push_back(cur);
        cur.clear();
      } else {
        cur.push_back(char(c));
      }
    }
    return out;
  };
  for (size_t r = 1; r < all.size(); ++r) {
    const std::vector<std::string> theirs = split(all[r]);
    if (theirs == mine) continue;
    size_t k = 0;
    while (k < mine.size() && k < theirs.size() && mine[k] == theirs[k]) ++k;
    const std::string a = k < mine.size() ? "'" + mine[k] + "'" : "nothing";
    const std::string b = k < theirs.size() ? "'" + theirs[k] + "'" : "nothing";
    comm.abort("the ranks were started with different options: rank " + std::to_string(r) + " has " + b +
               " where rank 0 has " + a + " (argument " + std::to_string(k + 1) +
               " after 'train', --threads and --quiet aside); every rank must run the same command");
  }
}

// Peak resident memory of this process (VmHWM), bytes; 0 when /proc is unavailable.
size_t peak_resident_bytes() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return size_t(std::strtoull(line.c_str() + 6, nullptr, 10)) * 1024;
  return 0;
}

// `train --merge`: no training, only the inputs' trees written as one forest.
int merge_main(const tools::Args& args, Communicator* comm) {
  if (comm && comm->size() > 1) tools::fail("--merge runs as one process, not as an MPI job");
  for (const char* other : {"--data", "--method", "--trees", "--structure", "--resume"})
    if (args.has(other)) tools::fail(std::string("--merge takes only --out (and --quiet), not ") + other);
  const std::vector<std::string> names = tools::split_list(args.get("--merge"));
  const std::string out_path = args.get("--out");
  std::vector<TrainedForest> inputs;
  for (const std::string& name : names) inputs.push_back(read_forest(name));
  const TrainedForest merged = merge_forests(inputs, names);
  write_forest(out_path, merged);
  if (!args.flag("--quiet")) {
    size_t leaves = 0;
    for (const TrainedTree& t : merged.trees) leaves += t.leaf_count();
    std::fprintf(stderr, "train: wrote %s: %zu tree(s) from %zu forests, %zu leaves\n", out_path.c_str(),
                 merged.trees.size(), inputs.size(), leaves);
  }
  return 0;
}

int train_main(int argc, char** argv, Communicator* comm) {
  tools::Args args(argc, argv, kUsage,
                   {"--data", "--method", "--trees", "--depth", "--out", "--objective", "--pixels-per-image",
                    "--images-per-tree", "--offsets", "--thresholds", "--max-offset", "--reference-focal",
                    "--min-samples", "--rho", "--nres", "--bandwidth", "--votes-per-leaf", "--vote-length",
                    "--structure", "--structure-min-pixels", "--structure-max-leaves", "--structure-depth", "--proposal", "--seed", "--threads", "--checkpoint", "--stop-after",
                    "--node-parallel-below", "--merge"},
                   {"--quiet", "--resume", "--distributed", "--no-timings"});
  if (args.help_requested()) {
    std::cout << kUsage;
    return 0;
  }
  if (args.has("--merge")) return merge_main(args, comm);
  const std::vector<std::string> dirs = tools::split_list(args.get("--data"));
  const std::string method = args.get("--method");
  const std::string out_path = args.get("--out");
  if (method != "bpc" && method != "ojr") tools::fail("--method must be bpc or ojr, got '" + method + "'");
  const std::string objective = args.get("--objective", "classification");
  if (objective != "classification" && objective != "regression")
    tools::fail("--objective must be classification or regression, got '" + objective + "'");
  const bool root = !comm || comm->rank() == 0;
  const bool quiet = args.flag("--quiet") || !root;  // only rank 0 reports progress
  if (comm) check_same_options(argc, argv, args.get("--checkpoint", out_path + ".checkpoint"), args.flag("--resume"), *comm);
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const int threads = static_cast<int>(args.get_int("--threads", hw));
  if (threads < 1 || threads > 256) tools::fail("--threads must be 1..256");

  std::unique_ptr<TrainedForest> structure, proposal_forest;
  if (args.has("--structure")) structure = std::make_unique<TrainedForest>(read_forest(args.get("--structure")));
  if (args.has("--structure-min-pixels")) {
    if (!structure) tools::fail("--structure-min-pixels needs --structure");
    const long long min_pixels = args.get_int("--structure-min-pixels", 0);
    if (min_pixels < 1) tools::fail("--structure-min-pixels must be >= 1, got " + std::to_string(min_pixels));
    PruneReport pruned;
    *structure = prune_structure(*structure, static_cast<uint64_t>(min_pixels), &pruned);
    if (!quiet)
      std::fprintf(stderr, "train: structure pruned at %lld pixels: %llu -> %llu leaves, depth %d -> %d\n", min_pixels,
                   (unsigned long long)pruned.leaves_before, (unsigned long long)pruned.leaves_after,
                   pruned.depth_before, pruned.depth_after);
  }
  if (args.has("--structure-max-leaves")) {
    if (!structure) tools::fail("--structure-max-leaves needs --structure");
    if (args.has("--structure-min-pixels")) tools::fail("--structure-max-leaves and --structure-min-pixels exclude each other");
    const long long max_leaves = args.get_int("--structure-max-leaves", 0);
    if (max_leaves < 1) tools::fail("--structure-max-leaves must be >= 1, got " + std::to_string(max_leaves));
    PruneReport pruned;
    *structure = prune_structure_by_gain(*structure, static_cast<uint64_t>(max_leaves), &pruned);
    if (!quiet)
      std::fprintf(stderr, "train: structure pruned by information gain to %lld leaves: %llu -> %llu leaves, depth %d -> %d\n",
                   max_leaves, (unsigned long long)pruned.leaves_before, (unsigned long long)pruned.leaves_after,
                   pruned.depth_before, pruned.depth_after);
  }
  if (args.has("--structure-depth")) {
    if (!structure) tools::fail("--structure-depth needs --structure");
    *structure = truncate_structure(*structure, static_cast<int>(args.get_int("--structure-depth", 0)));
  }
  std::unique_ptr<OffsetProposal> proposal;
  if (args.has("--proposal")) {
    proposal_forest = std::make_unique<TrainedForest>(read_forest(args.get("--proposal")));
    proposal = std::make_unique<OffsetProposal>(OffsetProposal::from_forest(*proposal_forest));
  }

  SamplingOptions so;
  so.pixels_per_image = static_cast<int>(args.get_int("--pixels-per-image", 2000));
  so.trees = structure ? static_cast<int>(structure->trees.size()) : static_cast<int>(args.get_int("--trees", 3));
  so.images_per_tree = static_cast<int>(args.get_int("--images-per-tree", 0));
  so.seed = static_cast<uint64_t>(args.get_int("--seed", 1));
  so.threads = threads;
  so.reference_focal_px = structure ? structure->reference_focal_px
                                    : static_cast<float>(args.get_double("--reference-focal", 0));
  so.need_labels = method == "bpc" || (objective == "classification" && !structure);
  so.need_joints = method == "ojr" || objective == "regression";
  if (comm) {
    so.shard = comm->rank();
    so.shards = comm->size();
  }
  if (so.trees < 1 || so.trees > 64) tools::fail("--trees must be 1..64");
  if (so.pixels_per_image < 1) tools::fail("--pixels-per-image must be >= 1");

  if (!quiet) std::fprintf(stderr, "train: loading %zu dataset(s)... (%s split-search kernels)\n", dirs.size(), training_kernel_name());
  const TrainingSet set = load_training_set(dirs, so);
  const size_t images_used = [&] {
    size_t n = 0;
    for (const auto& im : set.images) n += !im.probe.empty();
    return n;
  }();
  if (!quiet)
    std::fprintf(stderr, "train: %zu images, %zu training pixels over %zu tree(s), reference focal %.2f px, loaded in %s\n",
                 images_used, set.pixel_count(), set.tree_pixels.size(), set.reference_focal_px,
                 format_duration(set.load_seconds).c_str());

  ForestOptions fo;
  fo.method = method;
  fo.structure = structure.get();
  fo.pixels_per_image = so.pixels_per_image;
  fo.images_per_tree = so.images_per_tree;
  fo.tree.max_depth = static_cast<int>(args.get_int("--depth", 20));
  fo.tree.offset_candidates = static_cast<int>(args.get_int("--offsets", 2000));
  fo.tree.threshold_candidates = static_cast<int>(args.get_int("--thresholds", 50));
  fo.tree.max_offset_pxm = static_cast<int>(
      args.get_int("--max-offset", std::lround(129.0 * set.reference_focal_px / 525.0)));
  fo.tree.min_samples = static_cast<int>(args.get_int("--min-samples", 10));
  fo.tree.objective = objective == "classification" ? Objective::kClassification : Objective::kRegression;
  fo.tree.rho_m = static_cast<float>(args.get_double("--rho", 0.5));
  fo.tree.seed = so.seed;
  fo.tree.threads = threads;
  fo.tree.proposal = proposal.get();
  fo.tree.comm = comm;
  const long long node_parallel_below = args.get_int("--node-parallel-below", kDefaultNodeParallelPixels);
  if (node_parallel_below < 0 || node_parallel_below > kMaxNodeParallelPixels)
    tools::fail("--node-parallel-below must be 0.." + std::to_string(kMaxNodeParallelPixels) + " pixels");
  fo.tree.node_parallel_pixels = static_cast<uint32_t>(node_parallel_below);
  fo.leaf.reservoir = static_cast<int>(args.get_int("--nres", 100));
  fo.leaf.bandwidth_m = static_cast<float>(args.get_double("--bandwidth", 0.05));
  fo.leaf.votes_per_joint = static_cast<int>(args.get_int("--votes-per-leaf", 2));
  fo.leaf.seed = so.seed;
  fo.leaf.vote_length_m.clear();  // replaces LeafParams' default, not appended to it
  for (const std::string& v : tools::split_list(args.get("--vote-length", "0.5"))) {
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (*end || !(x >= 0)) tools::fail("--vote-length wants non-negative metres, got '" + v + "'");
    fo.leaf.vote_length_m.push_back(static_cast<float>(x));
  }

  fo.checkpoint_path = args.get("--checkpoint", out_path + ".checkpoint");
  fo.resume = args.flag("--resume");
  const long long stop_after = args.get_int("--stop-after", 0);
  if (stop_after < 0) tools::fail("--stop-after wants a number of levels >= 1");
  long long levels_checkpointed = 0;
  struct StopRequested {};
  if (stop_after > 0)
    fo.after_checkpoint = [&](int, int) {
      if (++levels_checkpointed == stop_after) throw StopRequested{};
    };
  // Only rank 0 fits (and checkpoints) retro-fitted votes, so only it could stop after a count.
  if (structure && comm && stop_after > 0) tools::fail("--stop-after with --structure needs a one-process run");
  if (!quiet && fo.resume)
    std::fprintf(stderr, "train: %s\n",
                 std::ifstream(fo.checkpoint_path).good()
                     ? ("resuming from checkpoint " + fo.checkpoint_path).c_str()
                     : ("no checkpoint at " + fo.checkpoint_path + ", starting from the beginning").c_str());

  const int trees = static_cast<int>(set.tree_pixels.size());
  const int depth = fo.tree.max_depth;
  double done_seconds = 0;  // trees grown (not replayed) to the end in this run
  int done_trees = 0;
  ProgressFn progress = [&](const LevelReport& r) {
    if (quiet) return;
    if (r.resumed) {
      std::fprintf(stderr, "train: tree %d/%d: levels 0..%d replayed from the checkpoint in %s\n", r.tree + 1, trees,
                   r.level, format_duration(r.tree_seconds).c_str());
      return;
    }
    if (r.partial) {
      const double level_left = r.done > 0 ? r.seconds * (1 - r.done) / r.done : 0;
      std::fprintf(stderr, "train: tree %d/%d level %2d/%d: %3.0f%% of the split search, %s (level ETA %s)\n",
                   r.tree + 1, trees, r.level, depth, 100 * r.done, format_duration(r.seconds).c_str(),
                   format_duration(level_left).c_str());
      return;
    }
    const double per_level = r.tree_seconds / (r.level + 1);
    const double tree_left = per_level * std::max(0, depth - r.level - 1);
    const double per_tree = done_trees == 0 ? per_level * depth : done_seconds / done_trees;
    const double eta = tree_left + per_tree * (trees - r.tree - 1);
    char traffic[128] = "";
    if (comm)
      std::snprintf(traffic, sizeof traffic, ", %.3f MB reduced + %.3f MB exchanged per rank, %zu node-parallel",
                    r.bytes_reduced / 1e6, r.bytes_exchanged / 1e6, r.node_parallel_nodes);
    std::fprintf(stderr,
                 "train: tree %d/%d level %2d/%d: %zu nodes, %zu split, %.2fM px, %.2f G evals%s, %s (tree %s, ETA <= %s)\n",
                 r.tree + 1, trees, r.level, depth, r.frontier_nodes, r.split_nodes, r.active_pixels / 1e6,
                 r.feature_evaluations / 1e9, traffic, format_duration(r.seconds).c_str(),
                 format_duration(r.tree_seconds).c_str(), format_duration(eta).c_str());
    if (r.split_nodes == 0 || r.level + 1 == depth) {
      done_seconds += r.tree_seconds;
      ++done_trees;
    }
  };
  // Retro-fit: one line per tree at most every 10 s, and at its end, with the time left for the
  // forest (trees are assumed to cost alike).
  const auto fit_start = std::chrono::steady_clock::now();
  auto last_line = fit_start - std::chrono::hours(1);
  if (structure && !quiet && root)
    fo.retrofit_progress = [&](int tree, size_t done, size_t leaves) {
      const auto now = std::chrono::steady_clock::now();
      if (done < leaves && now - last_line < std::chrono::seconds(10)) return;
      last_line = now;
      const double spent = std::chrono::duration<double>(now - fit_start).count();
      const double share = (tree + double(done) / double(leaves)) / trees;
      std::fprintf(stderr, "train: tree %d/%d votes: %zu/%zu leaves, %s (ETA %s)\n", tree + 1, trees, done, leaves,
                   format_duration(spent).c_str(), format_duration(share > 0 ? spent * (1 - share) / share : 0).c_str());
    };
  ForestStats stats;
  TrainedForest forest;
  try {
    forest = train_forest(set, fo, progress, &stats);
  } catch (const StopRequested&) {
    if (root)
      std::fprintf(stderr, "train: stopped after %lld checkpointed levels as asked (--stop-after); --resume continues from %s\n",
                   stop_after, fo.checkpoint_path.c_str());
    if (comm) comm->barrier();  // the checkpoint is written when any rank exits
    return 75;
  }
  if (args.flag("--no-timings")) forest.timings_json = "{}";
  if (root) {
    write_forest(out_path, forest);
    std::remove(fo.checkpoint_path.c_str());  // the forest supersedes it
  }
  if (comm) {
    // One line per rank (rank order is not guaranteed on a shared terminal; each names its rank).
    const auto [first, last] = rank_share(set.images.size(), comm->rank(), comm->size());
    if (!args.flag("--quiet"))
      std::fprintf(stderr,
                   "train: rank %d of %d: images %zu..%zu (%zu loaded, %.1f MB), %zu training pixels, %.3f MB "
                   "reduced + %.3f MB exchanged in %.2f s, peak resident %.1f MB\n",
                   comm->rank(), comm->size(), first, last, images_used, set.image_bytes() / 1e6, set.pixel_count(),
                   comm->bytes_reduced() / 1e6, comm->bytes_exchanged() / 1e6, comm->seconds_reducing(),
                   peak_resident_bytes() / 1e6);
    comm->barrier();  // rank 0 has written the forest when any rank exits 0
  }
  if (!quiet) {
    size_t nodes = 0, leaves = 0;
    for (const TrainedTree& t : forest.trees) {
      nodes += t.nodes.size();
      leaves += t.leaf_count();
    }
    const double rate = stats.structure_seconds > 0 ? stats.feature_evaluations / stats.structure_seconds : 0;
    std::fprintf(stderr,
                 "train: wrote %s: %d tree(s), %zu nodes, %zu leaves; structure %s, leaves %s; %.3g pixel*offset "
                 "evaluations/s (%.3g per thread); memory %.0f bytes per training pixel (images %.1f MB, tree "
                 "working set %.1f MB), peak resident %.1f MB\n",
                 out_path.c_str(), trees, nodes, leaves, format_duration(stats.structure_seconds).c_str(),
                 format_duration(stats.leaf_seconds).c_str(), rate, rate / threads, stats.bytes_per_pixel,
                 set.image_bytes() / 1e6, stats.peak_bytes / 1e6, peak_resident_bytes() / 1e6);
  }
  return 0;
}

// Distributed when an MPI launcher started this process (or --distributed).
int run_train(int argc, char** argv) { return run_maybe_distributed("depthpose train", argc, argv, train_main); }

}  // namespace
}  // namespace dp::train

DP_REGISTER_COMMAND(train, "train", "train a BPC or OJR decision forest from datasets (writes a .forest)",
                    dp::train::run_train);
