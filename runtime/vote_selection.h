// Vote selection (stage 3's second half): keeping each joint's top-Nsub votes, and the floor guesses
// that let the fast casters reject most candidates before appending them.
//
// The kept set of a joint is the Nsub heaviest of its candidates under one total order: weight,
// then tie_key(order) (casting orders are unique and tie_key is a bijection, so the set is unique).
// The reference casters find it with a bounded min-heap (push_top_n); the fast casters append to a
// buffer and cut it (cut_votes) when full, which keeps the same set in casting order.
// Buffers: joint j's votes at sets.votes[j · kVoteSlots ...], its count at sets.counts[j].
// Everything works in the caller's arena; no allocation, loops bounded by kVoteSlots.
#pragma once
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "runtime/kernels/vote_kernel.h"

namespace dp {

// Vote storage per joint: the reference keeps a top-N heap of at most Nsub ≤ kMaxVotesCap votes; the
// fast casters append up to 2·Nsub and select the top Nsub when full (amortized O(1) per vote).
constexpr int32_t kVoteSlots = 2 * blob::kMaxVotesCap;

struct VoteSets {
  Vote* votes;            // [kMaxJoints][kVoteSlots]
  int32_t* counts;        // [kMaxJoints]
  uint32_t* select_keys;  // scratch for cut_votes: 2·kVoteSlots entries
};

// Empties every joint's buffer.
void clear_votes(const VoteSets& sets);

// Equal weights are common (uniform leaves, flat regions); breaking ties by casting order would keep
// only the first pixels in raster order and bias the subsample towards the top of the image, so ties
// are broken by a fixed hash of the order instead (deterministic, spatially unbiased, a bijection).
inline uint32_t tie_key(uint32_t order) {
  uint32_t x = order * 0x9E3779B1u;
  x ^= x >> 15;
  x *= 0x85EBCA77u;
  x ^= x >> 13;
  return x;
}
inline bool lighter(const Vote& a, const Vote& b) {
  return a.weight < b.weight || (a.weight == b.weight && tie_key(a.order) < tie_key(b.order));
}

// Adds v to the min-heap `heap` of *count ≤ capacity votes, keeping the `capacity` heaviest.
// Returns true when a vote was dropped (the set was full).
bool push_top_n(Vote* heap, int32_t* count, int32_t capacity, const Vote& v);

// Cuts joint j's buffer (count > cap ≥ 1) to its cap heaviest votes, keeping their casting order;
// returns the lightest kept weight (the joint's floor from then on).
float cut_votes(const VoteSets& sets, int joint, int32_t cap);
// cut_votes as the scan kernels' callback for a full buffer: `ctx` is a CutWhenFull.
struct CutWhenFull {
  const VoteSets* sets;
  int32_t cap;
};
float cut_when_full(void* ctx, int joint);
// Cuts every joint's buffer to its cap heaviest votes. Returns true when votes were dropped.
bool finish_votes(const VoteSets& sets, int32_t cap);

// Floor guesses of the fast casters: about kFloorSamples sampled pixels (at most twice that), their
// weights counted per joint in kGuessBuckets buckets of 1/8 octave (float bits >> 20) from a lowest
// key up; lighter weights (and 0) share bucket 0. The histogram is [kMaxJoints][kGuessBuckets].
constexpr int32_t kFloorSamples = 512;
constexpr int32_t kMaxFloorSamples = 2 * kFloorSamples;
constexpr int32_t kGuessBuckets = 512;
constexpr int32_t kGuessPrefetchAhead = 8;  // samples: the rows/leaves are random reads beyond L1/L2
// BPC weights are ≤ 4096 (p ≤ 1, z ≤ 65.535 m), so the top bucket is never exceeded:
// key = (exponent + 127)·8 + top 3 mantissa bits.
constexpr int32_t kGuessLowestKey = (127 + 13) * 8 - kGuessBuckets;
// OJR weights are a uint16 vote weight · z² (< 2^29): the same buckets, 16 octaves higher.
constexpr int32_t kGuessLowestKeyOjr = (127 + 29) * 8 - kGuessBuckets;

// The bucket key of weight w ≥ 0 (clamped to the histogram).
inline int32_t guess_bucket(float w, int32_t lowest_key) {
  uint32_t bits;
  __builtin_memcpy(&bits, &w, sizeof bits);
  const int32_t key = int32_t(bits >> 20) - lowest_key;
  return key < 0 ? 0 : (key >= kGuessBuckets ? kGuessBuckets - 1 : key);
}

// The lower edge of the highest bucket of `hist` at which `rank` samples are reached from above, or
// −1 (no guess) when the rank falls to bucket 0.
float floor_at_rank(const uint16_t* hist, int32_t rank, int32_t lowest_key);

}  // namespace dp
