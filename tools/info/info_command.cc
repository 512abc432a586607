// `depthpose info BLOB`: describes a blob; on a bad blob prints one line naming the problem.
#include <cstdio>
#include <cstring>
#include <string>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "runtime/depthpose.h"
#include "runtime/kernels/forest_kernel.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/info/info.h"
#include "tools/common/blob_error.h"

namespace dp::tools {

static const char* kind_name(uint32_t k) {
  switch (k) {
    case 1: return "meta";
    case 2: return "config";
    case 3: return "split_nodes";
    case 4: return "split_flags";
    case 5: return "leaf_offsets";
    case 6: return "leaf_entries";
    case 7: return "entry_tags";
  }
  return "?";
}

void describe_blob(const blob::LoadedBlob& b, FILE* out) {
  const blob::BlobHeader& h = *b.header;
  const blob::ForestMeta& m = *b.meta;
  const bool bpc = b.method() == blob::Method::kBpc;
  std::fprintf(out, "depthpose forest blob v%u.%u, %llu bytes, header crc %08x, payload crc %08x\n",
               h.version_major, h.version_minor, (unsigned long long)h.total_bytes, h.header_crc32, h.payload_crc32);
  const auto* sections = reinterpret_cast<const blob::SectionEntry*>(reinterpret_cast<const uint8_t*>(&h) + sizeof h);
  for (uint32_t i = 0; i < h.section_count; ++i)
    std::fprintf(out, "  section %-12s offset %10llu size %10llu\n", kind_name(sections[i].kind),
                 (unsigned long long)sections[i].offset, (unsigned long long)sections[i].size);
  std::fprintf(out, "method %s, %d trees, depth %d, %u leaf records holding %u %s (%.2f per record), reference "
               "focal %.1f px\n", bpc ? "BPC" : "OJR", m.tree_count, m.depth, m.leaf_count, m.entry_count,
               bpc ? "part probabilities" : "votes", double(m.entry_count) / double(m.leaf_count), m.reference_focal_px);
  // The recorded figure is what the converting runtime needed; a later runtime may carve more
  // scratch, so the figure to size an arena by is the linked runtime's own.
  std::fprintf(out, "max probe offset %u pixel·m; arena for %ux%u frames: %zu bytes with this runtime "
               "(traversal tables %zu), %zu at least (%llu recorded at conversion)\n", m.max_abs_offset_pxm,
               m.max_width, m.max_height, required_arena_bytes(b, int32_t(m.max_width), int32_t(m.max_height)),
               b.total_nodes * (sizeof(kernels::SplitNode) + sizeof(uint32_t)), minimum_arena_bytes(b, int32_t(m.max_width), int32_t(m.max_height)), (unsigned long long)m.arena_bytes);
  // Per-tree statistics: split and leaf nodes (a full binary tree of n nodes has (n − 1) / 2 splits).
  for (int t = 0; t < m.tree_count; ++t)
    std::fprintf(out, "  tree %d: %u split nodes, %u leaf nodes\n", t, blob::split_nodes_of(b.tree_node_count(t)),
                 blob::leaf_nodes_of(b.tree_node_count(t)));
  std::fprintf(out, "parts (%d):", m.part_count);
  for (int i = 0; i < m.part_count; ++i) std::fprintf(out, " %s", m.part_names[i]);
  std::fprintf(out, "\njoints (%d):", m.joint_count);
  for (int i = 0; i < m.joint_count; ++i) std::fprintf(out, " %s", m.joint_names[i]);
  const blob::RuntimeConfig& c = *b.config;
  std::fprintf(out, "\nconfig: band %u..%u mm, Nsub %u, starts %u, iterations %u, proposals %u, merge %u mm, "
               "pixel budget %u, cycle budget %llu\n",
               c.near_mm, c.far_mm, c.max_votes_per_joint, c.max_starts_per_joint, c.mean_shift_iterations,
               c.max_proposals_per_joint, c.merge_tolerance_mm, c.max_evaluated_pixels,
               (unsigned long long)c.cycle_budget);
  for (int j = 0; j < m.joint_count; ++j) {
    const blob::JointConfig& jc = c.joints[j];
    if (bpc)
      std::fprintf(out, "  %-12s parts 0x%08x  lambda %.3f  push-back %d mm  bandwidth %u mm\n", m.joint_names[j],
                   jc.part_mask, jc.prob_threshold_q15 / 32768.0, jc.push_back_mm, jc.bandwidth_mm);
    else
      std::fprintf(out, "  %-12s vote length %u mm  bandwidth %u mm\n", m.joint_names[j], jc.vote_length_mm,
                   jc.bandwidth_mm);
  }
}

bool load_blob_or_explain(const std::string& path, std::vector<uint8_t>& bytes, blob::LoadedBlob* out,
                          std::string* problem) {
  bytes = blob::read_blob_file(path);
  blob::BlobProblem field;
  const blob::BlobStatus s = blob::load_blob(bytes.data(), bytes.size(), out, &field);
  if (s == blob::BlobStatus::kOk) return true;
  *problem = path + ": " + blob_error_message(s, field);
  return false;
}

blob::LoadedBlob load_blob_file_checked(const std::string& path, std::vector<uint8_t>& bytes) {
  blob::LoadedBlob b;
  std::string problem;
  if (!load_blob_or_explain(path, bytes, &b, &problem)) fail(problem);
  return b;
}

// Other file kinds (e.g. trained forests) register a describer here.
static std::vector<InfoDescriber>& describers() {
  static std::vector<InfoDescriber> d;
  return d;
}
InfoDescriberRegistrar::InfoDescriberRegistrar(InfoDescriber d) { describers().push_back(d); }

static int run_info(int argc, char** argv) {
  Args args(argc, argv, "usage: depthpose info FILE\n  Describes a forest blob (or a trained .forest file).", {});
  if (args.help_requested()) {
    std::printf("%s\n", args.usage().c_str());
    return 0;
  }
  if (args.positional().size() != 1) fail("expected exactly one file\n" + args.usage());
  const std::string path = args.positional()[0];
  std::vector<uint8_t> bytes = blob::read_blob_file(path);
  if (bytes.size() >= 4) {
    uint32_t magic;
    std::memcpy(&magic, bytes.data(), 4);
    if (magic != blob::kMagic)
      for (const InfoDescriber& d : describers())
        if (d(path, bytes)) return 0;
  }
  blob::LoadedBlob b;
  blob::BlobProblem problem;
  const blob::BlobStatus s = blob::load_blob(bytes.data(), bytes.size(), &b, &problem);
  if (s != blob::BlobStatus::kOk) {
    std::fprintf(stderr, "depthpose info: %s: invalid blob: %s\n", path.c_str(), blob_error_message(s, problem).c_str());
    return 1;
  }
  describe_blob(b, stdout);
  return 0;
}

DP_REGISTER_COMMAND(info, "info", "describe a forest blob or trained forest file", run_info);

}  // namespace dp::tools
