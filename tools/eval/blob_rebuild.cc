#include "tools/eval/blob_rebuild.h"

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>

#include "tools/common/error.h"
#include "tools/common/blob_error.h"

namespace dp::tools {

blob::BlobContents contents_from_blob(const blob::LoadedBlob& b) { return blob::dense_contents(b); }

std::vector<uint8_t> blob_with_config(const blob::LoadedBlob& b, const blob::RuntimeConfig& config) {
  blob::BlobProblem problem;
  if (blob::BlobStatus s = blob::validate_config(*b.meta, config, &problem); s != blob::BlobStatus::kOk)
    fail("runtime config refused: " + blob_error_message(s, problem));
  blob::BlobContents c = contents_from_blob(b);
  c.config = config;
  return blob::write_blob(c);
}

void keep_first_trees(blob::BlobContents* c, int trees) {
  const int have = int(c->tree_nodes.size());
  if (trees < 1 || trees > have)
    fail("--trees " + std::to_string(trees) + " is outside 1.." + std::to_string(have) + " (the blob's trees)");
  const bool ojr = c->method == blob::Method::kOjr;
  const size_t stride = ojr ? c->joint_names.size() * size_t(c->votes_per_joint) : c->part_names.size();
  const size_t records = (ojr ? c->ojr_leaves.size() : c->bpc_leaves.size()) / stride;
  // The kept trees' records in the order their leaf nodes reach them first, and each leaf node's new index.
  std::vector<uint32_t> renumbered(records, UINT32_MAX), kept;
  for (int t = 0; t < trees; ++t)
    for (size_t m = 0; m < c->tree_nodes[size_t(t)].size(); ++m) {
      if (c->tree_left_child[size_t(t)][m] != m + 1) continue;  // a split node (a leaf node is its own left child)
      uint32_t& r = c->tree_leaf_index[size_t(t)][m];
      if (renumbered[r] == UINT32_MAX) {
        renumbered[r] = uint32_t(kept.size());
        kept.push_back(r);
      }
      r = renumbered[r];
    }
  auto gather = [&](auto& table) {
    std::remove_reference_t<decltype(table)> out;
    out.reserve(kept.size() * stride);
    for (const uint32_t r : kept) out.insert(out.end(), table.begin() + ptrdiff_t(r * stride), table.begin() + ptrdiff_t((r + 1) * stride));
    table = std::move(out);
  };
  if (ojr) gather(c->ojr_leaves); else gather(c->bpc_leaves);
  c->tree_nodes.resize(size_t(trees));
  c->tree_leaf_index.resize(size_t(trees));
  c->tree_left_child.resize(size_t(trees));
}

}  // namespace dp::tools
