// A small, portable pseudo-random generator (xoshiro256** seeded through splitmix64), so that a
// dataset is byte-identical for the same seed on any standard library. Per-frame streams are
// derived from (seed, frame index, stream tag); never shared between threads.
#pragma once
#include <cmath>
#include <cstdint>

namespace dp::synth {

inline uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class Rng {
 public:
  explicit Rng(uint64_t seed) {
    for (auto& w : s_) w = splitmix64(seed);
  }
  // Stream for one frame: independent of how many frames other threads have drawn.
  static Rng for_frame(uint64_t seed, uint64_t frame_index, uint64_t stream) {
    uint64_t s = seed;
    uint64_t a = splitmix64(s);
    uint64_t f = frame_index * 0xD1B54A32D192ED03ull + stream * 0x8CB92BA72F3D8DD7ull;
    return Rng(a ^ splitmix64(f));
  }
  uint64_t next() {
    const uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  uint64_t below(uint64_t n) { return n ? next() % n : 0; }  // bias negligible for our n
  bool chance(double p) { return uniform() < p; }
  double gaussian() {  // Box-Muller, one value per call
    double u1 = uniform(), u2 = uniform();
    if (u1 < 1e-300) u1 = 1e-300;
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  int poisson(double mean) {  // Knuth; fine for small means
    double l = std::exp(-mean), p = 1.0;
    int k = 0;
    do {
      ++k;
      p *= uniform();
    } while (p > l && k < 1000);
    return k - 1;
  }

 private:
  static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t s_[4];
};

}  // namespace dp::synth
