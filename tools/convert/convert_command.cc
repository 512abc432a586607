// `depthpose convert`: model files → forest blob v1 (docs/convert.md).
#include <cstdio>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/convert/pcl_import.h"

namespace dp::tools {
namespace {

const char* const kUsage =
    "usage: depthpose convert --from-pcl TREE.txt.bz2 [TREE2 ...] --out BLOB\n"
    "  Imports PCL people-detector trees (bzip2 ASCII, read in place) as a 25-part BPC blob.\n"
    "  --out BLOB   blob to write (byte-identical for identical input)\n";

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
  Args args(argc, argv, kUsage, {"--out"}, {"--from-pcl"});
  if (args.help_requested()) {
    std::printf("%s", args.usage().c_str());
    return 0;
  }
  if (args.flag("--from-pcl")) return convert_from_pcl(args);
  fail("convert: give --from-pcl TREES (trained-forest input is not available in this build)\n" + args.usage());
}

}  // namespace

DP_REGISTER_COMMAND(convert, "convert", "model files (PCL trees) -> forest blob", convert_main);

}  // namespace dp::tools
