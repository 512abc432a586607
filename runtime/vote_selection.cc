#include "runtime/vote_selection.h"

#include <string.h>

#include <algorithm>

#include "runtime/debug_check.h"

namespace dp {

void clear_votes(const VoteSets& sets) {
  for (int j = 0; j < blob::kMaxJoints; ++j) sets.counts[j] = 0;
}

namespace {
// Min-heap on lighter(): the root is the lightest kept vote.
void heap_sift_down(Vote* h, int32_t n, int32_t i) {
  for (;;) {
    int32_t l = 2 * i + 1, r = l + 1, m = i;
    if (l < n && lighter(h[l], h[m])) m = l;
    if (r < n && lighter(h[r], h[m])) m = r;
    if (m == i) return;
    Vote t = h[i]; h[i] = h[m]; h[m] = t;
    i = m;
  }
}
void heap_sift_up(Vote* h, int32_t i) {
  while (i > 0) {
    int32_t p = (i - 1) / 2;
    if (!lighter(h[i], h[p])) return;
    Vote t = h[i]; h[i] = h[p]; h[p] = t;
    i = p;
  }
}

// Weights are ≥ 0, and non-negative floats order like their bit patterns.
inline uint32_t weight_bits(float w) {
  uint32_t bits;
  memcpy(&bits, &w, sizeof bits);
  return bits;
}
}  // namespace

bool push_top_n(Vote* heap, int32_t* count, int32_t capacity, const Vote& v) {
  DP_DCHECK(capacity >= 1 && capacity <= kVoteSlots && *count <= capacity);
  if (*count < capacity) {
    heap[*count] = v;
    heap_sift_up(heap, (*count)++);
    return false;
  }
  if (lighter(heap[0], v)) {
    heap[0] = v;
    heap_sift_down(heap, *count, 0);
  }
  return true;
}

// The selection runs on weight bits alone and hashes orders only for the votes tied at the boundary.
float cut_when_full(void* ctx, int joint) {
  const CutWhenFull* c = static_cast<const CutWhenFull*>(ctx);
  return cut_votes(*c->sets, joint, c->cap);
}

float cut_votes(const VoteSets& sets, int j, int32_t cap) {
  Vote* buf = sets.votes + size_t(j) * kVoteSlots;
  const int32_t n = sets.counts[j];
  DP_DCHECK(cap >= 1 && n > cap && n <= kVoteSlots);
  uint32_t* const bits = sets.select_keys;        // [kVoteSlots]
  uint32_t* const ties = bits + kVoteSlots;       // [kVoteSlots]
  // The cap-th heaviest weight by a radix step: a histogram of the top 11 weight bits (non-negative
  // floats are below 2^31, so bits >> 20 < kVoteSlots = 2^11 buckets), the bucket where the count
  // from the top reaches cap, then a selection among that bucket's weights alone.
  static_assert(kVoteSlots == 1 << 11, "one histogram bucket per slot of `ties`");
  uint32_t* const hist = ties;
  for (int32_t q = 0; q < kVoteSlots; ++q) hist[q] = 0;
  for (int32_t i = 0; i < n; ++i) {
    DP_DCHECK(weight_bits(buf[i].weight) < 0x80000000u);  // weights are ≥ +0
    ++hist[weight_bits(buf[i].weight) >> 20];
  }
  int32_t bucket = kVoteSlots - 1, above = 0;  // votes in buckets above `bucket`
  for (; bucket > 0 && above + int32_t(hist[bucket]) < cap; --bucket) above += int32_t(hist[bucket]);
  int32_t in_bucket = 0;
  for (int32_t i = 0; i < n; ++i) {
    const uint32_t w = weight_bits(buf[i].weight);
    if (w >> 20 == uint32_t(bucket)) bits[in_bucket++] = w;
  }
  const int32_t rank = cap - above;  // 1..in_bucket: the boundary is the rank-th heaviest in the bucket
  std::nth_element(bits, bits + (in_bucket - rank), bits + in_bucket);
  const uint32_t boundary = bits[in_bucket - rank];  // the cap-th heaviest weight
  int32_t heavier = 0, tied = 0;
  for (int32_t i = 0; i < n; ++i) {
    const uint32_t w = weight_bits(buf[i].weight);
    heavier += w > boundary;
    if (w == boundary) ties[tied++] = tie_key(buf[i].order);
  }
  const int32_t need = cap - heavier;  // 1..tied votes of the boundary weight are kept
  uint32_t lightest_tie = 0;           // keep boundary votes whose tie key is ≥ this
  if (need < tied) {
    std::nth_element(ties, ties + (tied - need), ties + tied);
    lightest_tie = ties[tied - need];
  }
  int32_t out = 0;
  for (int32_t i = 0; i < n; ++i) {
    const uint32_t w = weight_bits(buf[i].weight);
    if (w > boundary || (w == boundary && tie_key(buf[i].order) >= lightest_tie)) buf[out++] = buf[i];
  }
  sets.counts[j] = out;
  float floor;
  memcpy(&floor, &boundary, sizeof floor);
  return floor;
}

bool finish_votes(const VoteSets& sets, int32_t cap) {
  bool dropped = false;
  for (int j = 0; j < blob::kMaxJoints; ++j) {
    if (sets.counts[j] <= cap) continue;
    cut_votes(sets, j, cap);
    dropped = true;
  }
  return dropped;
}

float floor_at_rank(const uint16_t* hist, int32_t rank, int32_t lowest_key) {
  int32_t above = 0, b = kGuessBuckets - 1;
  for (; b > 0; --b)
    if ((above += hist[b]) >= rank) break;
  if (b == 0) return -1.0f;
  const uint32_t bits = uint32_t(b + lowest_key) << 20;
  float edge;
  memcpy(&edge, &bits, sizeof bits);
  return edge;
}

}  // namespace dp
