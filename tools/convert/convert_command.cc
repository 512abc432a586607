// `depthpose convert`: model files → forest blob (docs/convert.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/blob_error.h"
#include "tools/common/error.h"
#include "tools/common/limits.h"
#include "tools/convert/blob_upgrade.h"
#include "tools/convert/forest_convert.h"
#include "tools/convert/pcl_import.h"
#include "tools/eval/blob_rebuild.h"
#include "tools/train/forest_file.h"

namespace dp::tools {
namespace {

const char* const kUsage =
    "usage: depthpose convert FOREST --out BLOB [--max-size 640x480] [--check-frames 12]\n"
    "                         [--min-leaf-pixels N] [--max-bytes B]\n"
    "       depthpose convert --from-pcl TREE.txt.bz2 [TREE2 ...] --out BLOB\n"
    "       depthpose convert --upgrade-blob OLD.blob --out BLOB\n"
    "       depthpose convert --from-blob BLOB --trees N --out BLOB2\n"
    "  FOREST: a trained forest (depthpose train) quantized to fixed point (docs/convert.md); reports the\n"
    "  worst quantization error and checks that the blob's leaves equal the trained forest's on sample frames.\n"
    "  --from-pcl: imports PCL people-detector trees (bzip2 ASCII, read in place) as a 25-part BPC blob.\n"
    "  --upgrade-blob: rewrites a format-1 (dense leaves), format-2 (complete heap-order trees) or format-3\n"
    "  (stored child and leaf indices) blob as the current format 4 (split flags, compact leaves), losslessly\n"
    "  unless --bpc-*/--ojr-* options are given: every pixel reaches the same leaf contents, same config\n"
    "  (docs/blob_format.md).\n"
    "  --from-blob: the blob's first N trees and the leaf records they reach, config unchanged (tune it again).\n"
    "  --out BLOB       blob to write (byte-identical for identical input)\n"
    "  --max-size WxH   largest frame the blob's arena size is computed for (default 640x480)\n"
    "  --check-frames N sample frames for the leaf check (default 12, 0 = skip, at most 256)\n"
    "  --min-leaf-pixels N        BPC: collapse every subtree with fewer than N training pixels into one leaf\n"
    "                             (its pixels' merged part distribution; docs/convert.md, pruning)\n"
    "  --max-bytes B              the blob must fit B bytes: BPC is pruned at the smallest N (>= --min-leaf-pixels)\n"
    "                             whose blob fits, refused if one leaf per tree does not; OJR is refused above B\n"
    "  --trees N                  keep the forest's first N trees (default all)\n"
    "  --prune-by pixels|gain     how --max-bytes prunes BPC: subtrees below N training pixels (default), or\n"
    "                             the splits of least information gain first, keeping as many leaves as fit\n"
    "  --bpc-max-parts N          BPC leaves keep their N most probable parts (1..32, default %d)\n"
    "  --bpc-min-probability P    BPC leaves drop parts below P (0..1, default %.4f); dropped mass is\n"
    "                             not renormalized (docs/convert.md). 32 and 0: lossless\n"
    "  --ojr-max-votes N          OJR: each leaf and joint keeps its N heaviest votes (1..4, default %d)\n"
    "  --ojr-max-length M         OJR: votes longer than M metres are dropped and every joint's vote length\n"
    "                             is lowered to M (0..4, default %.3f; 0 = no limit)\n"
    "  --ojr-lengths-from BLOB    OJR: cut each joint's votes at that OJR blob's vote length for the joint\n"
    "                             (a tuned blob's: drops only votes it never casts; joints matched by name)\n"
    "  --ojr-min-share S          OJR: votes below S of their leaf and joint's vote weight are dropped (0..1,\n"
    "                             default %.3f). 4, 0, 0: lossless\n";

// The value of option `name` (a number in 0..limit), or `fallback` when it is not given.
double bounded_option(const Args& args, const std::string& name, double fallback, double limit) {
  if (!args.has(name)) return fallback;
  const std::string text = args.get(name);
  char* end = nullptr;
  const double p = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != 0 || !(p >= 0.0 && p <= limit))
    fail("convert: " + name + " '" + text + "' is not a number in 0.." + std::to_string(int(limit)));
  return p;
}

// The BPC compaction options over `k` (convert: BpcCompaction's measured defaults; --upgrade-blob:
// lossless unless asked).
BpcCompaction bpc_compaction_of(const Args& args, BpcCompaction k) {
  const long long parts = args.get_int("--bpc-max-parts", k.max_parts);
  if (parts < 1 || parts > blob::kMaxParts) fail("convert: --bpc-max-parts " + std::to_string(parts) + " is outside 1..32");
  k.max_parts = int(parts);
  if (args.has("--bpc-min-probability")) {
    const double p = bounded_option(args, "--bpc-min-probability", 0.0, 1.0);
    k.min_q15 = uint16_t(std::clamp<double>(std::ceil(p * 32768.0), 1.0, 32768.0));
  }
  return k;
}

// The OJR compaction options over `k` (convert: OjrCompaction's measured defaults; --upgrade-blob:
// lossless unless asked).
OjrCompaction ojr_compaction_of(const Args& args, OjrCompaction k) {
  const long long votes = args.get_int("--ojr-max-votes", k.max_votes);
  if (votes < 1 || votes > blob::kMaxVotesPerLeafJoint)
    fail("convert: --ojr-max-votes " + std::to_string(votes) + " is outside 1.." +
         std::to_string(blob::kMaxVotesPerLeafJoint));
  k.max_votes = int(votes);
  k.max_length_mm = uint16_t(std::lround(
      1000.0 * bounded_option(args, "--ojr-max-length", k.max_length_mm / 1000.0, blob::kMaxVoteLengthMm / 1000.0)));
  k.min_share = bounded_option(args, "--ojr-min-share", k.min_share, 1.0);
  if (args.has("--ojr-lengths-from")) {
    if (args.has("--ojr-max-length")) fail("convert: --ojr-lengths-from and --ojr-max-length exclude each other");
    const std::string path = args.get("--ojr-lengths-from");
    const std::vector<uint8_t> bytes = blob::read_blob_file(path);
    const blob::LoadedBlob tuned = load_blob_or_fail(bytes, path);
    if (tuned.method() != blob::Method::kOjr) fail("convert: --ojr-lengths-from " + path + " is not an OJR blob");
    k.joint_max_length_mm.clear();
    for (int j = 0; j < int(tuned.meta->joint_count); ++j) {
      k.joint_max_length_mm.push_back(tuned.config->joints[j].vote_length_mm);
      k.joint_names.push_back(std::string(tuned.meta->joint_names[j], strnlen(tuned.meta->joint_names[j], blob::kNameBytes)));
    }
  }
  return k;
}

void print_ojr_compaction(const OjrCompactionReport& r) {
  std::printf("OJR compaction: %llu of %llu votes kept (dropped: %llu too long, %llu below the weight share, %llu "
              "beyond the votes per joint)\n",
              (unsigned long long)r.votes_after, (unsigned long long)r.votes_before, (unsigned long long)r.dropped_long,
              (unsigned long long)r.dropped_light, (unsigned long long)r.dropped_beyond_k);
}

void print_compaction(const CompactionReport& r) {
  std::printf("BPC compaction: %llu parts dropped, dropped mass per leaf mean %.5f, worst %.4f\n",
              (unsigned long long)r.dropped_parts, r.mean_dropped_mass, r.worst_dropped_mass);
}

int convert_trained(const Args& args) {
  if (args.positional().size() != 1) fail("convert: give exactly one FOREST file\n" + args.usage());
  const std::string in = args.positional()[0];
  const std::string out = args.get("--out");
  ConvertOptions options;
  const std::string size = args.get("--max-size", "640x480");
  unsigned w = 0, h = 0;
  char x = 0;
  if (std::sscanf(size.c_str(), "%u%c%u", &w, &x, &h) != 3 || x != 'x' || w < 1 || h < 1 ||
      w > unsigned(blob::kMaxFrameDimension) || h > unsigned(blob::kMaxFrameDimension))
    fail("convert: --max-size '" + size + "' is not WxH within 1.." + std::to_string(blob::kMaxFrameDimension));
  options.max_width = w;
  options.max_height = h;
  options.bpc = bpc_compaction_of(args, BpcCompaction{});
  options.ojr = ojr_compaction_of(args, OjrCompaction{});
  const long long check_frames = args.get_int("--check-frames", 12);
  if (check_frames < 0 || check_frames > limits::kMaxCheckFrames)
    fail("convert: --check-frames " + std::to_string(check_frames) + " is outside 0.." +
         std::to_string(limits::kMaxCheckFrames) + " sample frames (docs/limits.md)");
  PruneBudget budget;
  const long long min_leaf_pixels = args.get_int("--min-leaf-pixels", 0);
  if (min_leaf_pixels < 0 || min_leaf_pixels > UINT32_MAX)
    fail("convert: --min-leaf-pixels " + std::to_string(min_leaf_pixels) + " is outside 0..4294967295 training pixels");
  budget.min_leaf_pixels = uint64_t(min_leaf_pixels);
  const long long max_bytes = args.get_int("--max-bytes", 0);
  if (args.has("--max-bytes") && max_bytes < 1)
    fail("convert: --max-bytes " + std::to_string(max_bytes) + " is not a positive number of bytes");
  budget.max_bytes = uint64_t(max_bytes);
  const std::string prune_by = args.get("--prune-by", "pixels");
  if (prune_by != "pixels" && prune_by != "gain")
    fail("convert: --prune-by '" + prune_by + "' is not pixels or gain");
  budget.by_gain = prune_by == "gain";
  if (budget.by_gain && !args.has("--max-bytes")) fail("convert: --prune-by gain needs --max-bytes");
  train::TrainedForest trained = train::read_forest(in);
  if (args.has("--trees")) {
    const long long trees = args.get_int("--trees", 0);
    if (trees < 1 || trees > (long long)trained.trees.size())
      fail("convert: --trees " + std::to_string(trees) + " is outside 1.." + std::to_string(trained.trees.size()) +
           " (the trees of " + in + ")");
    trained.trees.resize(size_t(trees));
  }
  const BudgetedBlob converted = convert_within_budget(trained, options, budget, in);
  const train::TrainedForest& forest = converted.forest;
  const QuantizationReport& rep = converted.quantization;
  const std::vector<uint8_t>& bytes = converted.bytes;
  std::printf("%s: %s forest, %zu trees, blob depth %d (%llu leaf nodes)\n", in.c_str(), forest.method.c_str(),
              forest.trees.size(), rep.blob_depth, (unsigned long long)rep.leaf_nodes);
  if (converted.min_leaf_pixels > 0)
    std::printf("pruned at %llu training pixels per subtree (%d blobs built): %llu -> %llu leaves, depth %d -> %d\n",
                (unsigned long long)converted.min_leaf_pixels, converted.conversions,
                (unsigned long long)converted.prune.leaves_before, (unsigned long long)converted.prune.leaves_after,
                converted.prune.depth_before, converted.prune.depth_after);
  if (converted.max_leaves > 0)
    std::printf("pruned by information gain to %llu leaves (%d blobs built): %llu -> %llu leaves, depth %d -> %d\n",
                (unsigned long long)converted.max_leaves, converted.conversions,
                (unsigned long long)converted.prune.leaves_before, (unsigned long long)converted.prune.leaves_after,
                converted.prune.depth_before, converted.prune.depth_after);
  std::printf("quantization: thresholds and offsets exact; worst probability error %.3g (bound 2^-15 = %.3g)",
              rep.worst_probability_error, 1.0 / 32768.0);
  if (forest.method == "ojr")
    std::printf("; worst vote offset error %.3f mm (bound 0.5), %llu clamped components, worst weight error %.3g "
                "(relative), %llu votes dropped beyond K=%d",
                rep.worst_vote_offset_error_mm, (unsigned long long)rep.clamped_vote_components,
                rep.worst_vote_weight_rel_error, (unsigned long long)rep.dropped_votes, blob::kMaxVotesPerLeafJoint);
  std::printf("\n");
  if (forest.method == "bpc") print_compaction(rep.bpc_compaction);
  if (forest.method == "ojr") print_ojr_compaction(rep.ojr_compaction);
  if (check_frames > 0) {
    const int cw = int(std::min<unsigned>(w, 320)), ch = int(std::min<unsigned>(h, 240));
    const LeafCheck check = check_leaves(forest, bytes, sample_frames(cw, ch, int(check_frames)), cw, ch,
                                         forest.reference_focal_px * float(cw) / 640.0f);
    std::printf("leaf check: %llu pixel-tree evaluations on %lld sample frames, %llu mismatches\n",
                (unsigned long long)check.pixels, check_frames, (unsigned long long)check.mismatches);
    if (check.mismatches != 0)
      fail(in + ": blob leaves differ from the trained forest on " + std::to_string(check.mismatches) +
           " pixel-tree evaluations (not written)");
  }
  blob::save_blob_file(out, bytes);
  std::printf("wrote %s: %zu bytes\n", out.c_str(), bytes.size());
  return 0;
}

int convert_from_pcl(const Args& args) {
  const std::vector<std::string>& inputs = args.positional();
  if (inputs.empty()) fail("convert --from-pcl: no tree files given\n" + args.usage());
  const std::string out = args.get("--out");
  std::vector<PclTree> trees;
  for (const std::string& path : inputs) {
    trees.push_back(read_pcl_tree(path));
    std::fprintf(stderr, "read %s: depth %d, %zu nodes\n", path.c_str(), trees.back().depth, trees.back().nodes.size());
  }
  const std::vector<uint8_t> bytes = blob::write_blob(pcl_blob_contents(trees));
  blob::save_blob_file(out, bytes);
  std::printf("wrote %s: %zu bytes, %zu PCL trees, %d parts\n", out.c_str(), bytes.size(), trees.size(), kPclPartCount);
  return 0;
}

int convert_upgrade(const Args& args) {
  const std::string in = args.get("--upgrade-blob");
  if (!args.positional().empty()) fail("convert --upgrade-blob: takes no FOREST\n" + args.usage());
  const std::string out = args.get("--out");
  const std::vector<uint8_t> old_bytes = blob::read_blob_file(in);
  int old_version = 0;
  blob::BlobContents contents = read_old_blob(old_bytes, in, &old_version);
  const CompactionReport compaction =
      compact_bpc_leaves(&contents, bpc_compaction_of(args, BpcCompaction{blob::kMaxParts, 1}));
  if (contents.method == blob::Method::kBpc) print_compaction(compaction);
  const OjrCompactionReport ojr = compact_ojr_leaves(&contents, ojr_compaction_of(args, OjrCompaction{blob::kMaxVotesPerLeafJoint, 0, 0.0}));
  if (contents.method == blob::Method::kOjr) print_ojr_compaction(ojr);
  const std::vector<uint8_t> bytes = blob::write_blob(contents);
  blob::save_blob_file(out, bytes);
  std::printf("wrote %s: %zu bytes (format %d: %zu bytes)\n", out.c_str(), bytes.size(), old_version, old_bytes.size());
  return 0;
}

int convert_from_blob(const Args& args) {
  const std::string in = args.get("--from-blob");
  if (!args.positional().empty()) fail("convert --from-blob: takes no FOREST\n" + args.usage());
  if (!args.has("--trees")) fail("convert --from-blob: give --trees N (the trees to keep)");
  for (const char* option : {"--upgrade-blob", "--max-size", "--check-frames", "--bpc-max-parts", "--bpc-min-probability",
                             "--ojr-max-votes", "--ojr-max-length", "--ojr-min-share", "--ojr-lengths-from", "--prune-by"})
    if (args.has(option)) fail(std::string("convert --from-blob: ") + option + " does not apply to a blob's trees");
  const std::string out = args.get("--out");
  const std::vector<uint8_t> bytes = blob::read_blob_file(in);
  const blob::LoadedBlob b = load_blob_or_fail(bytes, in);
  blob::BlobContents c = contents_from_blob(b);
  const long long trees = args.get_int("--trees", 0);
  keep_first_trees(&c, int(std::clamp<long long>(trees, -1, 1 << 20)));
  const std::vector<uint8_t> kept = blob::write_blob(c);
  blob::save_blob_file(out, kept);
  std::printf("wrote %s: %zu bytes, %lld of %d trees (%s: %zu bytes)\n", out.c_str(), kept.size(), trees, b.tree_count(),
              in.c_str(), bytes.size());
  return 0;
}

int convert_main(int argc, char** argv) {
  static const std::string usage = [] {
    const BpcCompaction k;
    const OjrCompaction o;
    char text[4096];
    std::snprintf(text, sizeof text, kUsage, k.max_parts, k.min_q15 / 32768.0, o.max_votes, o.max_length_mm / 1000.0,
                  o.min_share);
    return std::string(text);
  }();
  Args args(argc, argv, usage.c_str(),
            {"--out", "--max-size", "--check-frames", "--upgrade-blob", "--from-blob", "--bpc-max-parts", "--bpc-min-probability",
             "--ojr-max-votes", "--ojr-max-length", "--ojr-min-share", "--ojr-lengths-from", "--trees", "--min-leaf-pixels", "--max-bytes", "--prune-by"},
            {"--from-pcl"});
  if (args.help_requested()) {
    std::printf("%s", args.usage().c_str());
    return 0;
  }
  if ((args.flag("--from-pcl") || args.has("--upgrade-blob") || args.has("--from-blob")) &&
      (args.has("--min-leaf-pixels") || args.has("--max-bytes")))
    fail("convert: --min-leaf-pixels and --max-bytes prune a trained FOREST (by its leaves' training pixel counts, "
         "which blobs and PCL trees do not carry)");
  if (args.flag("--from-pcl")) return convert_from_pcl(args);
  if (args.has("--upgrade-blob")) return convert_upgrade(args);
  if (args.has("--from-blob")) return convert_from_blob(args);
  return convert_trained(args);
}

}  // namespace

DP_REGISTER_COMMAND(convert, "convert", "trained forest or PCL trees -> forest blob (fixed point)", convert_main);

}  // namespace dp::tools
