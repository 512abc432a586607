#include "forest_blob/blob_loader.h"

#include <string.h>

namespace dp::blob {

const char* blob_status_message(BlobStatus s) {
  switch (s) {
    case BlobStatus::kOk: return "ok";
    case BlobStatus::kNullInput: return "no blob bytes given";
    case BlobStatus::kBadAlignment: return "blob bytes are not 8-byte aligned in memory";
    case BlobStatus::kTooSmall: return "file too small to be a depthpose blob (truncated header)";
    case BlobStatus::kBadMagic: return "not a depthpose blob (bad magic)";
    case BlobStatus::kWrongEndianness: return "blob was written big-endian; this build reads little-endian only";
    case BlobStatus::kBadEndianTag: return "corrupt endianness tag";
    case BlobStatus::kVersionTooOld:
      return "blob format major version too old: versions 1 (dense leaves), 2 (complete heap-order trees) and 3 "
             "(stored child and leaf indices) are no longer read, this build reads version 4 (split flags, "
             "compact leaves); rewrite it with `depthpose convert --upgrade-blob OLD.blob --out NEW.blob`";
    case BlobStatus::kVersionTooNew: return "blob format major version too new for this build";
    case BlobStatus::kBadHeaderSize: return "header size disagrees with the section count";
    case BlobStatus::kTruncated: return "blob truncated (fewer bytes than its header declares)";
    case BlobStatus::kTrailingBytes: return "unexpected bytes after the end the header declares";
    case BlobStatus::kHeaderChecksum: return "header checksum mismatch (corrupt header)";
    case BlobStatus::kPayloadChecksum: return "payload checksum mismatch (corrupt data)";
    case BlobStatus::kBadSectionCount: return "section count out of range";
    case BlobStatus::kSectionMisaligned: return "a section is not 64-byte aligned";
    case BlobStatus::kSectionOutOfBounds: return "a section lies outside the blob";
    case BlobStatus::kSectionOverlap: return "two sections (or a section and the header) overlap";
    case BlobStatus::kSectionMissing: return "a required section is missing";
    case BlobStatus::kSectionDuplicate: return "a section appears twice";
    case BlobStatus::kUnknownSection: return "unknown section kind";
    case BlobStatus::kBadSectionSize: return "a section's size disagrees with the forest meta";
    case BlobStatus::kBadMethod: return "unknown method (neither BPC nor OJR)";
    case BlobStatus::kBadTreeCount: return "tree count out of range";
    case BlobStatus::kBadDepth: return "tree depth out of range";
    case BlobStatus::kBadPartCount: return "part count out of range";
    case BlobStatus::kBadJointCount: return "joint count out of range";
    case BlobStatus::kBadVotesPerJoint: return "votes per joint out of range";
    case BlobStatus::kBadFocalLength: return "reference focal length not positive and finite";
    case BlobStatus::kBadLeafCount: return "leaf count is not the forest's number of leaf nodes";
    case BlobStatus::kBadEntryCount: return "leaf entry count above leaf count times the entries a leaf can hold";
    case BlobStatus::kBadFrameSize: return "maximum frame size out of range";
    case BlobStatus::kBadName: return "a part or joint name is not NUL-terminated printable ASCII";
    case BlobStatus::kOffsetTooLarge: return "a node's probe offset exceeds the allowed radius";
    case BlobStatus::kBadLeafDistribution: return "a BPC leaf entry is 0 or a leaf distribution sums above 1";
    case BlobStatus::kBadVote: return "an OJR vote has weight 0 or an offset beyond the allowed length";
    case BlobStatus::kBadPartMask: return "a joint's part mask names a part the forest lacks";
    case BlobStatus::kBadConfig: return "a runtime config value is outside its range";
    case BlobStatus::kReservedNotZero: return "a reserved field is not zero";
    case BlobStatus::kEmpty: return "blob is empty (0 bytes)";
    case BlobStatus::kBadLeafOffsets: return "leaf offsets do not start at 0, decrease, or do not end at the entry count";
    case BlobStatus::kBadEntryTag: return "a leaf entry's part or lane is out of range or not strictly increasing";
    case BlobStatus::kBadNodeCount: return "a tree's node count is even, 0 or above what its depth allows";
    case BlobStatus::kBadChildIndex: return "a split node's children lie outside its tree";
    case BlobStatus::kTreeTooDeep: return "a split node lies at or below the tree depth (a walk would not end on a leaf)";
    case BlobStatus::kUnreachedNode: return "a tree node is not reached from the root";
  }
  return "unknown status";
}

namespace {

bool names_ok(const char (*names)[kNameBytes], int count, int capacity) {
  for (int i = 0; i < capacity; ++i) {
    const char* n = names[i];
    bool terminated = false;
    for (int k = 0; k < kNameBytes; ++k) {
      if (n[k] == 0) {
        terminated = true;
        for (int r = k; r < kNameBytes; ++r)
          if (n[r] != 0) return false;  // padding must be zero
        break;
      }
      if (n[k] < 0x20 || n[k] > 0x7E || i >= count) return false;
    }
    if (!terminated) return false;
  }
  return true;
}

int abs16(int16_t v) { return v < 0 ? -int(v) : int(v); }

// True when lo ≤ v ≤ hi; otherwise records the field, value and range in *p (when given).
bool in_range(BlobProblem* p, const char* field, int32_t joint, int64_t v, int64_t lo, int64_t hi) {
  if (v >= lo && v <= hi) return true;
  if (p) {
    p->field = field;
    p->joint = joint;
    p->value = v;
    p->min = lo;
    p->max = hi;
  }
  return false;
}

BlobStatus validate_meta(const ForestMeta& m, BlobProblem* p) {
  if (!in_range(p, "meta.method", -1, m.method, uint8_t(Method::kBpc), uint8_t(Method::kOjr)))
    return BlobStatus::kBadMethod;
  if (!in_range(p, "meta.tree_count", -1, m.tree_count, 1, kMaxTrees)) return BlobStatus::kBadTreeCount;
  if (!in_range(p, "meta.depth", -1, m.depth, 1, kMaxDepth)) return BlobStatus::kBadDepth;
  const bool bpc = m.method == uint8_t(Method::kBpc);
  if (!in_range(p, "meta.part_count", -1, m.part_count, bpc ? 1 : 0, kMaxParts)) return BlobStatus::kBadPartCount;
  if (!in_range(p, "meta.joint_count", -1, m.joint_count, bpc ? 0 : 1, kMaxJoints)) return BlobStatus::kBadJointCount;
  if (!in_range(p, "meta.votes_per_joint", -1, m.votes_per_joint, bpc ? 0 : 1, bpc ? 0 : kMaxVotesPerLeafJoint))
    return BlobStatus::kBadVotesPerJoint;
  if (!(m.reference_focal_px > 0.0f && m.reference_focal_px < 1e6f)) return BlobStatus::kBadFocalLength;
  if (!in_range(p, "meta.leaf_count", -1, m.leaf_count, 1, int64_t(m.tree_count) * int64_t(leaves_per_tree(m.depth))))
    return BlobStatus::kBadLeafCount;
  if (!in_range(p, "meta.entry_count", -1, m.entry_count, 0, int64_t(m.leaf_count) * max_entries_per_leaf(m)))
    return BlobStatus::kBadEntryCount;
  if (!in_range(p, "meta.max_width", -1, m.max_width, 1, kMaxFrameDimension) ||
      !in_range(p, "meta.max_height", -1, m.max_height, 1, kMaxFrameDimension))
    return BlobStatus::kBadFrameSize;
  if (!in_range(p, "meta.max_abs_offset_pxm", -1, m.max_abs_offset_pxm, 0, kMaxProbeOffsetPxm))
    return BlobStatus::kOffsetTooLarge;
  if (m.reserved0 != 0 || m.reserved1 != 0 || m.reserved2 != 0) return BlobStatus::kReservedNotZero;
  int64_t leaf_nodes = 0;
  for (int t = 0; t < kMaxTrees; ++t) {
    if (!in_range(p, "meta.node_count[t]", -1, m.node_count[t], t < m.tree_count ? 1 : 0,
                  t < m.tree_count ? int64_t(max_nodes_per_tree(m.depth)) : 0))
      return BlobStatus::kBadNodeCount;
    if (t < m.tree_count) {
      if (m.node_count[t] % 2 == 0) return BlobStatus::kBadNodeCount;  // a full binary tree has 2S + 1 nodes
      leaf_nodes += leaf_nodes_of(m.node_count[t]);
    }
  }
  if (!in_range(p, "meta.leaf_count", -1, m.leaf_count, leaf_nodes, leaf_nodes)) return BlobStatus::kBadLeafCount;
  if (!names_ok(m.part_names, m.part_count, kMaxParts) || !names_ok(m.joint_names, m.joint_count, kMaxJoints))
    return BlobStatus::kBadName;
  return BlobStatus::kOk;
}

// One tree's split flags (blob_format.h kSplitFlags): every node reached from the root, every split
// node's children inside the tree and no split node at level ≥ `depth`; the flag bits past the node
// count zero. One forward sweep: in breadth-first order the level boundaries are known from the
// children already seen, so no per-node state is kept.
BlobStatus validate_tree(const uint8_t* flags, uint32_t count, int depth) {
  uint32_t next_child = 2;    // the next split node's left child (breadth-first: 2k for the k-th)
  uint32_t level_last = 1;    // last node of the current level
  int level = 0;
  for (uint32_t m = 1; m <= count; ++m) {
    if (m > level_last) {     // the next level: the children of this level's split nodes
      ++level;
      level_last = next_child - 1;
      if (m > level_last) return BlobStatus::kUnreachedNode;
    }
    if (!((flags[(m - 1) >> 3] >> ((m - 1) & 7)) & 1u)) continue;  // a leaf node
    if (next_child >= count) return BlobStatus::kBadChildIndex;    // right child next_child + 1 ≤ count
    if (level >= depth) return BlobStatus::kTreeTooDeep;
    next_child += 2;          // ≤ count + 1: no overflow
  }
  if (count % 8 != 0 && (flags[count >> 3] >> (count % 8)) != 0) return BlobStatus::kReservedNotZero;
  return next_child - 1 == count ? BlobStatus::kOk : BlobStatus::kUnreachedNode;
}

}  // namespace

BlobStatus validate_config(const ForestMeta& m, const RuntimeConfig& c, BlobProblem* p) {
  const bool bpc = m.method == uint8_t(Method::kBpc);
  for (int j = 0; j < kMaxJoints; ++j) {
    const JointConfig& jc = c.joints[j];
    if (jc.reserved != 0) return BlobStatus::kReservedNotZero;
    if (j >= m.joint_count) continue;
    if (bpc) {
      // Bits 0..part_count−1 only, at least one (part_count ≤ 32 is validated with the meta).
      const int64_t all_parts = m.part_count >= 32 ? int64_t(0xFFFFFFFFu) : (int64_t(1) << m.part_count) - 1;
      if (!in_range(p, "config.joints[j].part_mask", j, jc.part_mask, 1, all_parts)) return BlobStatus::kBadPartMask;
      if (!in_range(p, "config.joints[j].prob_threshold_q15", j, jc.prob_threshold_q15, 0, kProbabilityOneQ15))
        return BlobStatus::kBadConfig;
    }
    if (!in_range(p, "config.joints[j].bandwidth_mm", j, jc.bandwidth_mm, 1, kMaxBandwidthMm) ||
        !in_range(p, "config.joints[j].push_back_mm", j, jc.push_back_mm, -kMaxPushBackMm, kMaxPushBackMm) ||
        !in_range(p, "config.joints[j].vote_length_mm", j, jc.vote_length_mm, 0, kMaxVoteLengthMm))
      return BlobStatus::kBadConfig;
  }
  if (!in_range(p, "config.far_mm", -1, c.far_mm, 1, kMaxFarMm) ||
      !in_range(p, "config.near_mm", -1, c.near_mm, 0, int64_t(c.far_mm) - 1) ||
      !in_range(p, "config.max_votes_per_joint", -1, c.max_votes_per_joint, 1, kMaxVotesCap) ||
      !in_range(p, "config.max_starts_per_joint", -1, c.max_starts_per_joint, 1, kMaxStartsCap) ||
      !in_range(p, "config.mean_shift_iterations", -1, c.mean_shift_iterations, 1, kMaxMeanShiftIterations) ||
      !in_range(p, "config.max_proposals_per_joint", -1, c.max_proposals_per_joint, 1, kMaxProposalsCap) ||
      !in_range(p, "config.merge_tolerance_mm", -1, c.merge_tolerance_mm, 1, kMaxMergeToleranceMm) ||
      !in_range(p, "config.max_evaluated_pixels", -1, c.max_evaluated_pixels, 1, kMaxEvaluatedPixels))
    return BlobStatus::kBadConfig;
  if (c.reserved0 != 0 || c.reserved1 != 0) return BlobStatus::kReservedNotZero;
  return BlobStatus::kOk;
}

BlobStatus load_blob(const void* data, size_t size, LoadedBlob* out, BlobProblem* problem) {
  if (!out) return BlobStatus::kNullInput;
  if (size == 0) return BlobStatus::kEmpty;  // before the pointer: an empty buffer may have none
  if (!data) return BlobStatus::kNullInput;
  if (reinterpret_cast<uintptr_t>(data) % 8 != 0) return BlobStatus::kBadAlignment;
  const uint8_t* bytes = static_cast<const uint8_t*>(data);
  if (size < sizeof(BlobHeader)) return BlobStatus::kTooSmall;
  BlobHeader h;
  memcpy(&h, bytes, sizeof h);
  if (h.magic != kMagic) return BlobStatus::kBadMagic;
  if (h.endian_tag != kEndianTag)
    return h.endian_tag == 0x04030201u ? BlobStatus::kWrongEndianness : BlobStatus::kBadEndianTag;
  if (h.version_major < kVersionMajor) return BlobStatus::kVersionTooOld;
  if (h.version_major > kVersionMajor) return BlobStatus::kVersionTooNew;
  if (h.section_count < 1 || h.section_count > uint32_t(kMaxSections)) return BlobStatus::kBadSectionCount;
  if (h.header_bytes != sizeof(BlobHeader) + h.section_count * sizeof(SectionEntry)) return BlobStatus::kBadHeaderSize;
  if (size < h.header_bytes) return BlobStatus::kTruncated;
  if (h.total_bytes > size) return BlobStatus::kTruncated;
  if (h.total_bytes < size) return BlobStatus::kTrailingBytes;
  {
    // CRC of the header with the crc field zeroed: hash in three pieces to avoid a copy.
    const size_t crc_at = offsetof(BlobHeader, header_crc32);
    const uint32_t zero = 0;
    uint32_t c = crc32(bytes, crc_at);
    c = crc32(&zero, 4, c);
    c = crc32(bytes + crc_at + 4, h.header_bytes - crc_at - 4, c);
#ifndef DP_BLOB_FUZZING  // the fuzz build skips checksums so mutations reach the structural checks
    if (c != h.header_crc32) return BlobStatus::kHeaderChecksum;
#endif
  }
#ifndef DP_BLOB_FUZZING
  if (crc32(bytes + h.header_bytes, size_t(h.total_bytes - h.header_bytes)) != h.payload_crc32)
    return BlobStatus::kPayloadChecksum;
#endif
  if (h.flags != 0) return BlobStatus::kReservedNotZero;
  for (uint8_t r : h.reserved)
    if (r != 0) return BlobStatus::kReservedNotZero;

  // Section table.
  SectionEntry sections[kMaxSections];
  memcpy(sections, bytes + sizeof(BlobHeader), h.section_count * sizeof(SectionEntry));
  const SectionEntry* by_kind[kSectionKinds + 1] = {};
  for (uint32_t i = 0; i < h.section_count; ++i) {
    const SectionEntry& s = sections[i];
    if (s.kind < 1 || s.kind > kSectionKinds) return BlobStatus::kUnknownSection;
    if (s.reserved != 0) return BlobStatus::kReservedNotZero;
    if (by_kind[s.kind]) return BlobStatus::kSectionDuplicate;
    by_kind[s.kind] = &sections[i];
    if (s.offset % kSectionAlignment != 0) return BlobStatus::kSectionMisaligned;
    if (s.offset < h.header_bytes || s.offset > h.total_bytes || s.size > h.total_bytes - s.offset)
      return BlobStatus::kSectionOutOfBounds;
    for (uint32_t k = 0; k < i; ++k) {
      const SectionEntry& o = sections[k];
      if (s.offset < o.offset + o.size && o.offset < s.offset + s.size) return BlobStatus::kSectionOverlap;
    }
  }
  for (uint32_t k = 1; k <= kSectionKinds; ++k)
    if (!by_kind[k]) return BlobStatus::kSectionMissing;

  const SectionEntry& meta_s = *by_kind[int(SectionKind::kMeta)];
  if (meta_s.size != sizeof(ForestMeta)) return BlobStatus::kBadSectionSize;
  const ForestMeta* meta = reinterpret_cast<const ForestMeta*>(bytes + meta_s.offset);
  if (BlobStatus s = validate_meta(*meta, problem); s != BlobStatus::kOk) return s;

  const SectionEntry& config_s = *by_kind[int(SectionKind::kConfig)];
  if (config_s.size != sizeof(RuntimeConfig)) return BlobStatus::kBadSectionSize;
  const RuntimeConfig* config = reinterpret_cast<const RuntimeConfig*>(bytes + config_s.offset);
  if (BlobStatus s = validate_config(*meta, *config, problem); s != BlobStatus::kOk) return s;

  uint32_t tree_first[kMaxTrees] = {}, tree_first_split[kMaxTrees] = {}, tree_first_flag[kMaxTrees] = {},
           tree_first_leaf[kMaxTrees] = {};
  size_t node_count = 0, split_count = 0, flag_bytes = 0, leaf_nodes = 0;  // < 2^24 by the meta
  for (int t = 0; t < meta->tree_count; ++t) {
    tree_first[t] = uint32_t(node_count);
    tree_first_split[t] = uint32_t(split_count);
    tree_first_flag[t] = uint32_t(flag_bytes);
    tree_first_leaf[t] = uint32_t(leaf_nodes);
    node_count += meta->node_count[t];
    split_count += split_nodes_of(meta->node_count[t]);
    flag_bytes += split_flag_bytes_of(meta->node_count[t]);
    leaf_nodes += leaf_nodes_of(meta->node_count[t]);
  }
  const SectionEntry& nodes_s = *by_kind[int(SectionKind::kNodes)];
  const SectionEntry& flags_s = *by_kind[int(SectionKind::kSplitFlags)];
  const SectionEntry& offsets_s = *by_kind[int(SectionKind::kLeafOffsets)];
  const SectionEntry& entries_s = *by_kind[int(SectionKind::kLeafEntries)];
  const SectionEntry& tags_s = *by_kind[int(SectionKind::kEntryTags)];
  if (nodes_s.size != split_count * sizeof(TreeNode) || flags_s.size != flag_bytes) return BlobStatus::kBadSectionSize;
  if (offsets_s.size != (size_t(meta->leaf_count) + 1) * sizeof(uint32_t) ||
      entries_s.size != size_t(meta->entry_count) * leaf_entry_bytes(*meta) ||
      tags_s.size != size_t(meta->entry_count))
    return BlobStatus::kBadSectionSize;

  const TreeNode* split_nodes = reinterpret_cast<const TreeNode*>(bytes + nodes_s.offset);
  const uint8_t* split_flags = bytes + flags_s.offset;
  for (int t = 0; t < meta->tree_count; ++t) {
    const BlobStatus s = validate_tree(split_flags + tree_first_flag[t], meta->node_count[t], meta->depth);
    if (s != BlobStatus::kOk) return s;
  }
  const int offset_limit = int(meta->max_abs_offset_pxm);
  for (size_t i = 0; i < split_count; ++i) {
    const TreeNode& n = split_nodes[i];
    if (abs16(n.du1) > offset_limit || abs16(n.dv1) > offset_limit || abs16(n.du2) > offset_limit ||
        abs16(n.dv2) > offset_limit)
      return BlobStatus::kOffsetTooLarge;
  }

  // Compact leaves: each record's entry range inside the table, its tags strictly increasing below
  // the record's capacity (so no record exceeds max_entries_per_leaf), every entry nonzero.
  const uint32_t* offsets = reinterpret_cast<const uint32_t*>(bytes + offsets_s.offset);
  const uint8_t* entries = bytes + entries_s.offset;
  const uint8_t* tags = bytes + tags_s.offset;
  if (offsets[0] != 0 || offsets[meta->leaf_count] != meta->entry_count) return BlobStatus::kBadLeafOffsets;
  for (uint32_t l = 0; l < meta->leaf_count; ++l)
    if (offsets[l + 1] < offsets[l]) return BlobStatus::kBadLeafOffsets;
  const int capacity = max_entries_per_leaf(*meta);
  const bool bpc = meta->method == uint8_t(Method::kBpc);
  const uint16_t* probabilities = reinterpret_cast<const uint16_t*>(entries);
  const OjrVote* votes = reinterpret_cast<const OjrVote*>(entries);
  for (uint32_t l = 0; l < meta->leaf_count; ++l) {
    uint32_t sum = 0;
    int previous_tag = -1;
    for (uint32_t e = offsets[l]; e < offsets[l + 1]; ++e) {
      if (int(tags[e]) <= previous_tag || int(tags[e]) >= capacity) return BlobStatus::kBadEntryTag;
      previous_tag = tags[e];
      if (bpc) {
        if (probabilities[e] == 0) return BlobStatus::kBadLeafDistribution;
        sum += probabilities[e];  // ≤ 32 entries of ≤ 65535: no overflow
      } else {
        const OjrVote& v = votes[e];
        if (v.weight == 0 || abs16(v.dx_mm) > kMaxVoteOffsetMm || abs16(v.dy_mm) > kMaxVoteOffsetMm ||
            abs16(v.dz_mm) > kMaxVoteOffsetMm)
          return BlobStatus::kBadVote;
      }
    }
    if (sum > kProbabilityOneQ15) return BlobStatus::kBadLeafDistribution;
  }

  out->header = reinterpret_cast<const BlobHeader*>(bytes);
  out->meta = meta;
  out->config = config;
  out->split_nodes = split_nodes;
  out->split_flags = split_flags;
  for (int t = 0; t < kMaxTrees; ++t) {
    out->tree_first[t] = tree_first[t];
    out->tree_first_split[t] = tree_first_split[t];
    out->tree_first_flag[t] = tree_first_flag[t];
    out->tree_first_leaf[t] = tree_first_leaf[t];
  }
  out->total_nodes = node_count;
  out->leaf_offsets = offsets;
  out->leaf_entries = entries;
  out->entry_tags = tags;
  return BlobStatus::kOk;
}

void expand_tree_tables(const LoadedBlob& b, TreeNode* nodes, uint32_t* left_child, uint32_t* leaf_index) {
  for (int t = 0; t < b.tree_count(); ++t) {
    const size_t first = b.tree_first[t];
    for_each_tree_node(b, t, [&](uint32_t m, const TreeNode& node, uint32_t left, uint32_t record) {
      if (nodes) nodes[first + m - 1] = node;
      if (left_child) left_child[first + m - 1] = left;
      if (leaf_index) leaf_index[first + m - 1] = record;
    });
  }
}

}  // namespace dp::blob
