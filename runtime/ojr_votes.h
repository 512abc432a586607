// OJR vote casting (stage 3 for offset-joint-regression forests; votes.h describes the stage).
// Each leaf record holds up to K votes per joint (offsets in mm, a uint16 weight ≥ 1), stored
// compactly in lane (joint, k) order (forest_blob/blob_format.h); a pixel's vote for joint j is its
// 3D point plus the offset, weight w·z², dropped when |offset| > vote_length_mm (0 = no limit). A vote's casting order depends on (pixel, tree, k) only, never on other joints'
// length filters, so each joint's proposals depend only on its own JointConfig (tune relies on this).
#pragma once
#include <stdint.h>

#include "runtime/kernels/vote_kernel.h"
#include "runtime/votes.h"

namespace dp {

// The live-vote copy: for each leaf record, those of its stored votes that are candidates under a
// config (weight ≠ 0 and |offset|² within the lane's vote length²), in the record's order, with their
// lanes. The fast caster scans it instead of the blob's tables and so reads only candidates: same
// votes in the same order, hence the same kept votes, while the length test no longer rejects most
// of what it reads (the shipped OJR blob under its own config: 13 % of its 600 355 stored votes are
// candidates, docs/runtime_speed.md). The pipeline carves it at init with the optional copies
// (required_arena_bytes) and rebuilds it whenever the config changes.
// Arena bytes: ojr_live_vote_bytes(); blobs above kMaxOjrLiveEntries stored votes are scanned in place.
// The cap admits the depth-20 OJR blobs of `make model` (the shipped one: 705 743 stored votes; one of
// 1 094 457, a 9.9 MB copy, cut at 0.3 m instead of its tuned lengths): scanned in place, the latter's votes cost 3.6–4.6 M cycles per 320×240 frame of bench_runtime's rendered people,
// against 1.8–2.2 M with the copy (OJR 427 → 554–646 frames/s, two alternated runs).
constexpr uint32_t kMaxOjrLiveEntries = 1u << 21;  // votes; bounds the copy at 18 MB + the offsets
inline bool use_ojr_live_votes(const blob::LoadedBlob& b) {
  return b.method() == blob::Method::kOjr && b.meta->entry_count <= kMaxOjrLiveEntries;
}
// Fills the copy (offsets: leaf_count + 1 entries, votes and lanes: entry_count each, the worst case
// of any config) for `config`.
void build_ojr_live_votes(const blob::LoadedBlob& b, const blob::RuntimeConfig& config, uint32_t* offsets,
                          blob::OjrVote* votes, uint8_t* lanes);

// Squared vote length per lane j·K + k for `config` (mm²; |offset|² ≤ 3·2^30 and a limit² < 2^32 both
// fit uint32): joint j's vote_length_mm², or 2^32 − 1 when it is 0 (no limit). `out`: kMaxOjrLanes.
void ojr_lane_len2(const blob::LoadedBlob& b, const blob::RuntimeConfig& config, uint32_t* out);

// The fast caster's floor guess aims at kOjrGuessQuarterNsubs / 4 · Nsub votes per joint at or
// above it (unit: quarters of Nsub; range 4..8: below Nsub a guess too high and its rescan become
// common). Fewer appended votes mean fewer and smaller cuts. Chosen by instruction counts
// (callgrind, 24 held-out frames, shipped OJR): the vote stage 112.7 M at 8 quarters (2·Nsub),
// 99.6 M at 6, 93.0 M at 5 (no rescans there); 6 keeps a margin against rescans on other frames.
constexpr int32_t kOjrGuessQuarterNsubs = 6;

// The reference caster: every pixel, tree, joint and k in order into a top-Nsub heap. Returns
// kFlagVotesTruncated or 0 (votes.h).
uint32_t cast_ojr_votes_reference(const CastInputs& in, const VoteSets& sets);
// The fast caster: the same kept votes (in casting order) by `scan`, over in.ojr_live when it is set,
// else over the blob's tables.
uint32_t cast_ojr_votes_fast(const CastInputs& in, kernels::OjrScanFn scan, const VoteSets& sets);

}  // namespace dp
