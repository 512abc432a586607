#include "tools/eval/blob_rebuild.h"

#include <cstring>
#include <string>

#include "tools/common/error.h"
#include "tools/common/blob_error.h"

namespace dp::tools {

blob::BlobContents contents_from_blob(const blob::LoadedBlob& b) {
  const blob::ForestMeta& m = *b.meta;
  blob::BlobContents c;
  c.method = b.method();
  c.depth = m.depth;
  c.reference_focal_px = m.reference_focal_px;
  for (int i = 0; i < m.part_count; ++i) c.part_names.emplace_back(m.part_names[i], strnlen(m.part_names[i], blob::kNameBytes));
  for (int i = 0; i < m.joint_count; ++i) c.joint_names.emplace_back(m.joint_names[i], strnlen(m.joint_names[i], blob::kNameBytes));
  c.votes_per_joint = c.method == blob::Method::kOjr ? m.votes_per_joint : 0;
  for (int t = 0; t < b.tree_count(); ++t) {
    c.tree_nodes.emplace_back(b.tree_nodes(t), b.tree_nodes(t) + blob::nodes_per_tree(m.depth));
    c.tree_leaf_index.emplace_back(b.tree_leaf_index(t), b.tree_leaf_index(t) + blob::leaves_per_tree(m.depth));
  }
  if (c.method == blob::Method::kBpc) {
    c.bpc_leaves.reserve(size_t(m.leaf_count) * m.part_count);
    for (uint32_t l = 0; l < m.leaf_count; ++l) c.bpc_leaves.insert(c.bpc_leaves.end(), b.bpc_leaf(l), b.bpc_leaf(l) + m.part_count);
  } else {
    const size_t per_leaf = size_t(m.joint_count) * m.votes_per_joint;
    c.ojr_leaves.reserve(size_t(m.leaf_count) * per_leaf);
    for (uint32_t l = 0; l < m.leaf_count; ++l) c.ojr_leaves.insert(c.ojr_leaves.end(), b.ojr_leaf(l), b.ojr_leaf(l) + per_leaf);
  }
  c.config = *b.config;
  c.max_width = m.max_width;
  c.max_height = m.max_height;
  return c;
}

std::vector<uint8_t> blob_with_config(const blob::LoadedBlob& b, const blob::RuntimeConfig& config) {
  blob::BlobProblem problem;
  if (blob::BlobStatus s = blob::validate_config(*b.meta, config, &problem); s != blob::BlobStatus::kOk)
    fail("runtime config refused: " + blob_error_message(s, problem));
  blob::BlobContents c = contents_from_blob(b);
  c.config = config;
  return blob::write_blob(c);
}

}  // namespace dp::tools
