// Memory for a runtime arena (Pipeline, Segmenter): one anonymous mapping, zero-filled, owned by the
// ArenaMemory and unmapped with it. When the arena is at least 2 MiB it is aligned to 2 MiB and
// advised as backed by transparent huge pages (madvise MADV_HUGEPAGE).
//
// Why: the split node copy of a deep forest (31.5 MB for PCL's three depth-20 trees) is read at random
// on the deep tree levels; on 4 KiB pages those reads also miss the TLB. With 2 MiB pages the forest
// stage measured 2-4 % less time per node visit (docs/runtime_speed.md, "Arena memory"). The advice
// changes nothing but speed: where the kernel's transparent huge pages are off, or the advice is
// refused, the arena is ordinary pages.
#pragma once
#include <cstddef>
#include <cstdint>

namespace dp::platform {

class ArenaMemory {
 public:
  static constexpr size_t kHugePageBytes = size_t(2) << 20;

  ArenaMemory() = default;
  // bytes > 0. Throws tools::ToolError naming the size when the mapping is refused.
  explicit ArenaMemory(size_t bytes);
  ~ArenaMemory();
  ArenaMemory(ArenaMemory&& other) noexcept;
  ArenaMemory& operator=(ArenaMemory&& other) noexcept;
  ArenaMemory(const ArenaMemory&) = delete;
  ArenaMemory& operator=(const ArenaMemory&) = delete;

  uint8_t* data() const { return data_; }
  size_t size() const { return size_; }  // the bytes asked for (the mapping may be larger)
  // True when the huge-page advice was given and accepted (not whether the kernel could honour it).
  bool huge_page_advice() const { return huge_page_advice_; }

 private:
  void release();
  uint8_t* data_ = nullptr;
  size_t size_ = 0, mapped_ = 0;
  bool huge_page_advice_ = false;
};

}  // namespace dp::platform
