// Bump allocation inside the caller's arena, used only by Pipeline::init (never per frame).
// Persistent blocks come from the tail, per-frame scratch from the head; a failed carve leaves
// the arena unchanged and returns nullptr, so init can report kArenaTooSmall.
#pragma once
#include <stddef.h>
#include <stdint.h>

namespace dp {

constexpr size_t kArenaAlignment = 64;

class ArenaCarver {
 public:
  ArenaCarver(uint8_t* base, size_t bytes) : base_(base), head_(0), tail_(bytes) {}
  // Counting mode (base == nullptr): only sizes are accumulated, for required_arena_bytes().
  template <typename T>
  T* head(size_t count) { return static_cast<T*>(take_head(count * sizeof(T))); }
  template <typename T>
  T* tail(size_t count) { return static_cast<T*>(take_tail(count * sizeof(T))); }
  bool ok() const { return ok_; }
  size_t used() const { return head_ + (capacity_ - tail_); }
  static size_t round_up(size_t v) { return (v + kArenaAlignment - 1) & ~(kArenaAlignment - 1); }

 private:
  void* take_head(size_t bytes) {
    const size_t n = round_up(bytes);
    if (!ok_ || n > tail_ - head_) { ok_ = false; return nullptr; }
    void* p = base_ ? base_ + head_ : nullptr;
    head_ += n;
    return p;
  }
  void* take_tail(size_t bytes) {
    const size_t n = round_up(bytes);
    if (!ok_ || n > tail_ - head_) { ok_ = false; return nullptr; }
    tail_ -= n;
    return base_ ? base_ + tail_ : nullptr;
  }
  uint8_t* base_;
  size_t head_, tail_;
  size_t capacity_ = tail_;
  bool ok_ = true;
};

}  // namespace dp
