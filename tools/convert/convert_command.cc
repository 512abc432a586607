// `depthpose convert`: model files → forest blob v1 (docs/convert.md).
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/common/limits.h"
#include "tools/convert/forest_convert.h"
#include "tools/convert/pcl_import.h"
#include "tools/train/forest_file.h"

namespace dp::tools {
namespace {

const char* const kUsage =
    "usage: depthpose convert FOREST --out BLOB [--max-size 640x480] [--check-frames 12]\n"
    "       depthpose convert --from-pcl TREE.txt.bz2 [TREE2 ...] --out BLOB\n"
    "  FOREST: a trained forest (depthpose train) quantized to fixed point (docs/convert.md); reports the\n"
    "  worst quantization error and checks that the blob's leaves equal the trained forest's on sample frames.\n"
    "  --from-pcl: imports PCL people-detector trees (bzip2 ASCII, read in place) as a 25-part BPC blob.\n"
    "  --out BLOB       blob to write (byte-identical for identical input)\n"
    "  --max-size WxH   largest frame the blob's arena size is computed for (default 640x480)\n"
    "  --check-frames N sample frames for the leaf check (default 12, 0 = skip, at most 256)\n";

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
  const long long check_frames = args.get_int("--check-frames", 12);
  if (check_frames < 0 || check_frames > limits::kMaxCheckFrames)
    fail("convert: --check-frames " + std::to_string(check_frames) + " is outside 0.." +
         std::to_string(limits::kMaxCheckFrames) + " sample frames (docs/limits.md)");
  const train::TrainedForest forest = train::read_forest(in);
  QuantizationReport rep;
  const std::vector<uint8_t> bytes = blob::write_blob(convert_forest(forest, options, in, &rep));
  std::printf("%s: %s forest, %zu trees, blob depth %d (%llu padded nodes)\n", in.c_str(), forest.method.c_str(),
              forest.trees.size(), rep.blob_depth, (unsigned long long)rep.padded_nodes);
  std::printf("quantization: thresholds and offsets exact; worst probability error %.3g (bound 2^-15 = %.3g)",
              rep.worst_probability_error, 1.0 / 32768.0);
  if (forest.method == "ojr")
    std::printf("; worst vote offset error %.3f mm (bound 0.5), %llu clamped components, worst weight error %.3g "
                "(relative), %llu votes dropped beyond K=%d",
                rep.worst_vote_offset_error_mm, (unsigned long long)rep.clamped_vote_components,
                rep.worst_vote_weight_rel_error, (unsigned long long)rep.dropped_votes, blob::kMaxVotesPerLeafJoint);
  std::printf("\n");
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

int convert_main(int argc, char** argv) {
  Args args(argc, argv, kUsage, {"--out", "--max-size", "--check-frames"}, {"--from-pcl"});
  if (args.help_requested()) {
    std::printf("%s", args.usage().c_str());
    return 0;
  }
  if (args.flag("--from-pcl")) return convert_from_pcl(args);
  return convert_trained(args);
}

}  // namespace

DP_REGISTER_COMMAND(convert, "convert", "trained forest or PCL trees -> forest blob (fixed point)", convert_main);

}  // namespace dp::tools
