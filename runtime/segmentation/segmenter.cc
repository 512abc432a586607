#include "runtime/segmentation/segmenter.h"

#include <math.h>
#include <string.h>
#include <x86intrin.h>

#include "runtime/arena.h"

namespace dp {

namespace {

inline uint64_t cycles_now() { return __rdtsc(); }

inline uint32_t xorshift32(uint32_t* s) {
  uint32_t x = *s;
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  *s = x;
  return x;
}

struct Plane {
  float nx, ny, nz, d;
};

// Orients the plane so the camera (origin) is on its positive side, then checks it can be a floor
// seen by this camera: normal near the camera's up axis, camera height in range.
bool orient_and_check(Plane* p, float min_up, float h_min, float h_max) {
  if (p->d < 0.0f) {
    p->nx = -p->nx; p->ny = -p->ny; p->nz = -p->nz; p->d = -p->d;
  }
  return p->ny >= min_up && p->d >= h_min && p->d <= h_max;
}

bool plane_from_points(const float* a, const float* b, const float* c, Plane* p) {
  const float ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const float vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  float nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  const float len = sqrtf(nx * nx + ny * ny + nz * nz);
  if (!(len > 1e-6f)) return false;  // collinear or repeated points
  nx /= len; ny /= len; nz /= len;
  *p = Plane{nx, ny, nz, -(nx * a[0] + ny * a[1] + nz * a[2])};
  return true;
}

int32_t count_inliers(const Plane& p, const float* pts, int32_t n, float tol_m, uint8_t* mark,
                      int32_t* below = nullptr) {
  int32_t count = 0, under = 0;
  const float under_m = tol_m * 3.0f > 0.1f ? tol_m * 3.0f : 0.1f;
  for (int32_t i = 0; i < n; ++i) {
    const float* q = pts + 3 * i;
    const float s = p.nx * q[0] + p.ny * q[1] + p.nz * q[2] + p.d;
    const bool in = s <= tol_m && s >= -tol_m;
    if (mark) mark[i] = in;
    count += in;
    under += s < -under_m;
  }
  if (below) *below = under;
  return count;
}

// A floor has (almost) nothing under it; a table top or a box lid has the floor under it. Each
// point clearly below a hypothesis costs two inliers.
inline int32_t floor_score(int32_t inliers, int32_t below) { return inliers - 2 * below; }

// count_inliers for a RANSAC hypothesis that only matters when its floor_score beats `to_beat`:
// stops (returning false) as soon as even all remaining points being inliers could not. Same
// result as scoring every point whenever it returns true.
bool score_beats(const Plane& p, const float* pts, int32_t n, float tol_m, int32_t to_beat, int32_t* inliers,
                 int32_t* score) {
  int32_t count = 0, under = 0;
  const float under_m = tol_m * 3.0f > 0.1f ? tol_m * 3.0f : 0.1f;
  for (int32_t i = 0; i < n; ++i) {
    const float* q = pts + 3 * i;
    const float s = p.nx * q[0] + p.ny * q[1] + p.nz * q[2] + p.d;
    count += s <= tol_m && s >= -tol_m;
    under += s < -under_m;
    if ((i & 31) == 31 && floor_score(count, under) + (n - 1 - i) <= to_beat) return false;
  }
  *inliers = count;
  *score = floor_score(count, under);
  return *score > to_beat;
}

// Eigenvector of the smallest eigenvalue of a symmetric 3×3 matrix (cyclic Jacobi, ≤ 16 sweeps).
void smallest_eigenvector(const double in[3][3], double out[3]) {
  double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  memcpy(a, in, sizeof a);
  static const int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int sweep = 0; sweep < 16; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= 1e-30 * (diag + 1e-300)) break;
    for (const auto& pq : kPairs) {
      const int p = pq[0], q = pq[1];
      if (a[p][q] == 0.0) continue;
      const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
      const double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
      const double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
      // a ← Jᵀ a J, v ← v J with J the rotation in the (p, q) plane.
      for (int k = 0; k < 3; ++k) {
        const double akp = a[k][p], akq = a[k][q];
        a[k][p] = c * akp - s * akq;
        a[k][q] = s * akp + c * akq;
      }
      for (int k = 0; k < 3; ++k) {
        const double apk = a[p][k], aqk = a[q][k];
        a[p][k] = c * apk - s * aqk;
        a[q][k] = s * apk + c * aqk;
      }
      for (int k = 0; k < 3; ++k) {
        const double vkp = v[k][p], vkq = v[k][q];
        v[k][p] = c * vkp - s * vkq;
        v[k][q] = s * vkp + c * vkq;
      }
    }
  }
  int m = 0;
  if (a[1][1] < a[m][m]) m = 1;
  if (a[2][2] < a[m][m]) m = 2;
  for (int k = 0; k < 3; ++k) out[k] = v[k][m];
}

// Orthogonal least-squares plane through the marked points.
bool refine_plane(const float* pts, const uint8_t* mark, int32_t n, Plane* p) {
  double c[3] = {0, 0, 0};
  int32_t m = 0;
  for (int32_t i = 0; i < n; ++i) {
    if (!mark[i]) continue;
    for (int k = 0; k < 3; ++k) c[k] += pts[3 * i + k];
    ++m;
  }
  if (m < 3) return false;
  for (int k = 0; k < 3; ++k) c[k] /= m;
  double cov[3][3] = {};
  for (int32_t i = 0; i < n; ++i) {
    if (!mark[i]) continue;
    const double d[3] = {pts[3 * i] - c[0], pts[3 * i + 1] - c[1], pts[3 * i + 2] - c[2]};
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) cov[r][k] += d[r] * d[k];
  }
  double nrm[3];
  smallest_eigenvector(cov, nrm);
  const double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
  if (!(len > 0.5)) return false;
  *p = Plane{float(nrm[0] / len), float(nrm[1] / len), float(nrm[2] / len), 0.0f};
  p->d = float(-(p->nx * c[0] + p->ny * c[1] + p->nz * c[2]));
  return true;
}

inline float tolerance_mm(float base_mm, float per_m2_mm, float z_mm) {
  const float zm = z_mm * 0.001f;
  return base_mm + per_m2_mm * zm * zm;
}

// Running statistics of a component (Segmenter::Candidate): pixel count, centroid sums,
// extents, height range above the floor and image box. One place for the rules, so building a
// component, re-measuring a cut one and merging two agree.
template <class Stats>
inline void clear_stats(Stats& c) {
  c.pixels = 0;
  c.sx = c.sy = c.sz = 0.0;
  c.x_min = c.y_min = c.z_min = 1e30f;
  c.x_max = c.y_max = c.z_max = c.top = -1e30f;
  c.bottom = 1e30f;
  c.u_min = c.v_min = 32767;
  c.u_max = c.v_max = -1;
}

// (x, y, z): camera metres; horizontal: the point along the extent axis; up: height above the
// floor (only when a floor is known).
template <class Stats>
inline void add_point(Stats& c, int32_t u, int32_t v, float x, float y, float z, float horizontal) {
  ++c.pixels;
  c.sx += x; c.sy += y; c.sz += z;
  if (horizontal < c.x_min) c.x_min = horizontal;
  if (horizontal > c.x_max) c.x_max = horizontal;
  if (y < c.y_min) c.y_min = y;
  if (y > c.y_max) c.y_max = y;
  if (z < c.z_min) c.z_min = z;
  if (z > c.z_max) c.z_max = z;
  if (u < c.u_min) c.u_min = int16_t(u);
  if (u > c.u_max) c.u_max = int16_t(u);
  if (v < c.v_min) c.v_min = int16_t(v);
  if (v > c.v_max) c.v_max = int16_t(v);
}

template <class Stats>
inline void add_height(Stats& c, float up) {
  if (up > c.top) c.top = up;
  if (up < c.bottom) c.bottom = up;
}

// Without a floor, `top` is the y extent.
template <class Stats>
inline void add_stats(Stats& dst, const Stats& src, bool use_floor) {
  dst.pixels += src.pixels;
  dst.sx += src.sx; dst.sy += src.sy; dst.sz += src.sz;
  if (src.x_min < dst.x_min) dst.x_min = src.x_min;
  if (src.x_max > dst.x_max) dst.x_max = src.x_max;
  if (src.y_min < dst.y_min) dst.y_min = src.y_min;
  if (src.y_max > dst.y_max) dst.y_max = src.y_max;
  if (src.z_min < dst.z_min) dst.z_min = src.z_min;
  if (src.z_max > dst.z_max) dst.z_max = src.z_max;
  dst.top = use_floor ? (src.top > dst.top ? src.top : dst.top) : dst.y_max - dst.y_min;
  if (src.bottom < dst.bottom) dst.bottom = src.bottom;
  if (src.u_min < dst.u_min) dst.u_min = src.u_min;
  if (src.u_max > dst.u_max) dst.u_max = src.u_max;
  if (src.v_min < dst.v_min) dst.v_min = src.v_min;
  if (src.v_max > dst.v_max) dst.v_max = src.v_max;
}

// A component's pixels on the floor (split_box, low_person): a kCells × kCells grid of square
// cells of side cell_m centred on the component's mean point, along the floor's in-plane axes
// a (camera x without its part along the normal) and b = n × a, and each pixel's height above it.
struct FloorGrid {
  static constexpr int32_t kCells = 48;
  float ax, ay, az, bx, by, bz;
  // False when the floor normal is (nearly) camera x: no axis a.
  bool init(const FloorPlane& floor, const CameraIntrinsics& in, float mx, float my, float mz, float cell_m) {
    nx = floor.nx; ny = floor.ny; nz = floor.nz; d = floor.d;
    ax = 1.0f - nx * nx; ay = -nx * ny; az = -nx * nz;
    const float len = sqrtf(ax * ax + ay * ay + az * az);
    if (len < 1e-3f) return false;
    ax /= len; ay /= len; az /= len;
    bx = ny * az - nz * ay; by = nz * ax - nx * az; bz = nx * ay - ny * ax;
    inv_cell = 1.0f / cell_m;
    a0 = mx * ax + my * ay + mz * az;
    b0 = mx * bx + my * by + mz * bz;
    cx = in.cx; cy = in.cy;
    inv_fx = 1.0f / in.fx; inv_fy = 1.0f / in.fy;
    return true;
  }
  // init() centred on a candidate component's mean point (sums sx, sy, sz over `pixels`, > 0).
  template <class Component>
  bool init_at(const FloorPlane& floor, const CameraIntrinsics& in, const Component& c, float cell_m) {
    return init(floor, in, float(c.sx / c.pixels), float(c.sy / c.pixels), float(c.sz / c.pixels), cell_m);
  }
  // The cell of pixel (u, v) at depth_mm, or −1 off the grid; *up = its height above the floor.
  int32_t cell_of(int32_t u, int32_t v, uint16_t depth_mm, float* up) const {
    const float z = float(depth_mm) * 0.001f;
    const float x = (float(u) - cx) * z * inv_fx;
    const float y = -(float(v) - cy) * z * inv_fy;
    *up = nx * x + ny * y + nz * z + d;
    const int32_t ia = int32_t(floorf((x * ax + y * ay + z * az - a0) * inv_cell)) + kCells / 2;
    const int32_t ib = int32_t(floorf((x * bx + y * by + z * bz - b0) * inv_cell)) + kCells / 2;
    if (ia < 0 || ia >= kCells || ib < 0 || ib >= kCells) return -1;
    return ia * kCells + ib;
  }

 private:
  float nx, ny, nz, d, inv_cell, a0, b0, cx, cy, inv_fx, inv_fy;
};

}  // namespace

const char* segmentation_stage_name(int32_t stage) {
  static const char* const names[kSegStageCount] = {"seg_floor", "seg_background", "seg_components", "seg_users"};
  return stage >= 0 && stage < kSegStageCount ? names[stage] : "?";
}

SegmenterConfig default_segmenter_config(bool live_source) {
  SegmenterConfig c;
  c.background_enabled = live_source;
  return c;
}

bool Segmenter::carve(ArenaCarver& c, int32_t w, int32_t h, Segmenter* into) {
  const size_t pixels = size_t(w) * size_t(h);
  SegmenterConfig* config = c.tail<SegmenterConfig>(1);
  BackgroundCell* background = c.tail<BackgroundCell>(pixels);
  Track* tracks = c.tail<Track>(kMaxUsers);
  FloorPlane* floor = c.tail<FloorPlane>(1);
  State* state = c.tail<State>(1);
  int32_t* parent = c.head<int32_t>(pixels);
  int32_t* aux = c.head<int32_t>(pixels);
  float* samples = c.head<float>(size_t(kMaxFloorSamples) * 3);
  uint8_t* inlier = c.head<uint8_t>(kMaxFloorSamples);
  Candidate* candidates = c.head<Candidate>(kMaxCandidates);
  int16_t* hull_rows = c.head<int16_t>(size_t(h) * 4);
  if (!c.ok()) return false;
  if (into) {
    into->config_ = config;
    into->background_ = background;
    into->tracks_ = tracks;
    into->floor_ = floor;
    into->state_ = state;
    into->parent_ = parent;
    into->aux_ = aux;
    into->samples_ = samples;
    into->inlier_ = inlier;
    into->candidates_ = candidates;
    into->hull_rows_ = hull_rows;
  }
  return true;
}

size_t segmenter_required_bytes(int32_t max_width, int32_t max_height) {
  if (max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return 0;
  ArenaCarver counter(nullptr, size_t(-1) / 2);
  Segmenter::carve(counter, max_width, max_height, nullptr);
  return counter.used();
}

Status Segmenter::init(const SegmenterConfig& config, int32_t max_width, int32_t max_height, uint8_t* arena,
                       size_t arena_bytes) {
  initialized_ = false;
  if (!arena || max_width < 1 || max_height < 1 || max_width > blob::kMaxFrameDimension ||
      max_height > blob::kMaxFrameDimension)
    return Status::kBadArgument;
  if (reinterpret_cast<uintptr_t>(arena) % kArenaAlignment != 0) return Status::kArenaMisaligned;
  if (arena_bytes < segmenter_required_bytes(max_width, max_height)) return Status::kArenaTooSmall;
  if (!segmenter_config_check(config)) return Status::kBadConfig;
  ArenaCarver c(arena, arena_bytes);
  if (!carve(c, max_width, max_height, this)) return Status::kArenaTooSmall;
  *config_ = config;
  max_width_ = max_width;
  max_height_ = max_height;
  arena_used_ = c.used();
  initialized_ = true;
  reset();
  return Status::kOk;
}

Status Segmenter::set_config(const SegmenterConfig& config) {
  if (!initialized_) return Status::kNotInitialized;
  if (!segmenter_config_check(config)) return Status::kBadConfig;
  *config_ = config;
  return Status::kOk;
}

void Segmenter::reset() {
  if (!initialized_) return;
  memset(background_, 0, sizeof(BackgroundCell) * size_t(max_width_) * size_t(max_height_));
  memset(tracks_, 0, sizeof(Track) * kMaxUsers);
  memset(floor_, 0, sizeof *floor_);
  memset(state_, 0, sizeof *state_);
}

Status Segmenter::process(const DepthFrame& f, SegmentationResult* r) {
  if (!r) return Status::kBadArgument;
  uint8_t* labels = r->labels;
  memset(r, 0, sizeof *r);
  r->labels = labels;
  if (!initialized_) return Status::kNotInitialized;
  if (!labels || !f.depth_mm || f.width < 1 || f.height < 1 || f.stride_px < f.width ||
      !(f.intrinsics.fx > 0.0f) || !(f.intrinsics.fy > 0.0f))
    return Status::kBadArgument;
  if (f.width > max_width_ || f.height > max_height_) return Status::kFrameTooLarge;
  if (state_->width != f.width || state_->height != f.height) {
    reset();
    state_->width = f.width;
    state_->height = f.height;
  }
  const uint64_t t0 = cycles_now();
  fit_floor(f, r);
  const uint64_t t1 = cycles_now();
  r->candidate_pixels = classify_pixels(f);
  const uint64_t t2 = cycles_now();
  const int32_t candidates = label_components(f, r);
  const uint64_t t3 = cycles_now();
  assign_users(f, candidates, r);
  if (config_->background_enabled) update_background(f, labels, r);
  if (state_->frames < config_->background_learn_frames && config_->background_enabled)
    r->flags |= kSegFlagBackgroundLearning;
  if (state_->frames < 0x7fffffff) ++state_->frames;
  const uint64_t t4 = cycles_now();
  r->stage_cycles[kSegStageFloor] = t1 - t0;
  r->stage_cycles[kSegStageBackground] = t2 - t1;
  r->stage_cycles[kSegStageComponents] = t3 - t2;
  r->stage_cycles[kSegStageUsers] = t4 - t3;
  r->total_cycles = t4 - t0;
  return Status::kOk;
}

void Segmenter::fit_floor(const DepthFrame& f, SegmentationResult* r) {
  const SegmenterConfig& cfg = *config_;
  if (!cfg.floor_enabled) {
    memset(floor_, 0, sizeof *floor_);
    r->floor = *floor_;
    return;
  }
  const int32_t w = f.width, h = f.height;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  // Bounded grid sample of the lower image part.
  int32_t rows = int32_t(ceilf(cfg.floor_sample_fraction * float(h)));
  if (rows < 1) rows = 1;
  if (rows > h) rows = h;
  const int32_t v0 = h - rows;
  int32_t step = int32_t(ceilf(sqrtf(float(rows) * float(w) / float(cfg.floor_samples))));
  if (step < 1) step = 1;
  int32_t n = 0;
  for (int32_t v = v0 + step / 2; v < h; v += step) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    for (int32_t u = step / 2; u < w && n < cfg.floor_samples; u += step) {
      const uint16_t z = row[u];
      if (z < cfg.near_mm || z > cfg.floor_far_mm) continue;
      const float zm = float(z) * 0.001f;
      float* p = samples_ + 3 * n++;
      p[0] = (float(u) - f.intrinsics.cx) * zm * inv_fx;
      p[1] = -(float(v) - f.intrinsics.cy) * zm * inv_fy;
      p[2] = zm;
    }
  }
  const float tol = cfg.floor_fit_mm * 0.001f;
  const float min_up = cosf(cfg.floor_max_tilt_deg * 3.14159265f / 180.0f);
  const bool had_plane = floor_->valid != 0;
  Plane best{0, 0, 0, 0};
  int32_t best_count = 0, best_score = 0, below = 0;
  if (had_plane) {
    best = Plane{floor_->nx, floor_->ny, floor_->nz, floor_->d};
    best_count = count_inliers(best, samples_, n, tol, nullptr, &below);
    best_score = floor_score(best_count, below);
  }
  // The cheap tracked search only when last frame's plane still explains most of what it did;
  // otherwise (camera moved, new scene) the full search.
  const bool tracking = had_plane && 2 * best_count >= floor_->inliers;
  const int32_t iterations = tracking ? cfg.floor_tracked_iterations : cfg.floor_iterations;
  uint32_t rng = 0x9E3779B9u ^ (uint32_t(state_->frames) * 0x85EBCA77u);
  if (rng == 0) rng = 1;
  auto search = [&](int32_t hypotheses) {
    for (int32_t it = 0; it < hypotheses && n >= 3; ++it) {
      const int32_t a = int32_t(xorshift32(&rng) % uint32_t(n));
      const int32_t b = int32_t(xorshift32(&rng) % uint32_t(n));
      const int32_t c = int32_t(xorshift32(&rng) % uint32_t(n));
      if (a == b || b == c || a == c) continue;
      Plane p;
      if (!plane_from_points(samples_ + 3 * a, samples_ + 3 * b, samples_ + 3 * c, &p)) continue;
      if (!orient_and_check(&p, min_up, cfg.camera_height_min_m, cfg.camera_height_max_m)) continue;
      int32_t count = 0, score = 0;
      if (score_beats(p, samples_, n, tol, best_score, &count, &score)) {
        best = p;
        best_count = count;
        best_score = score;
      }
    }
  };
  search(iterations);
  int32_t needed = int32_t(ceilf(cfg.floor_min_inlier_fraction * float(n)));
  if (needed < 3) needed = 3;
  // Where the floor is a small share of the sample (a far strip, mostly hidden by what stands in
  // front), 512 draws hold only a few all-floor triples and a frame can miss it by chance; then
  // (and only then) floor_retry_iterations more, continuing from the best so far.
  if (!tracking && (best_count < needed || best_score <= 0)) search(cfg.floor_retry_iterations);
  // A floor seen beyond furniture close to the camera (or past the people in front) holds only a
  // small share of the sample; it is taken with floor_wide_inlier_fraction when its inliers span
  // floor_wide_extent_m, more than any piece of furniture's top (a box or table top is a plane with
  // the floor under it too, and wins when the floor is that small a share).
  int32_t wide_needed = int32_t(ceilf(cfg.floor_wide_inlier_fraction * float(n)));
  if (wide_needed < 3) wide_needed = 3;
  if (wide_needed > needed) wide_needed = needed;
  bool fitted = false;
  if (best_count >= wide_needed && best_score > 0) {
    // Least-squares refinement on the inliers with a shrinking band: objects standing on the floor
    // put points just above it inside the RANSAC band and would tilt the plane; a symmetric band
    // around the refined plane keeps the fit unbiased under noise.
    // A refined plane outside the limits means the hypothesis only grazed a steeper (or otherwise
    // refused) surface near the limit: no floor then, rather than the grazing plane.
    static const float kBand[3] = {1.0f, 0.5f, 0.3f};
    bool refused = false;
    for (float band : kBand) {
      if (count_inliers(best, samples_, n, tol * band, inlier_) < 3) break;
      Plane p;
      if (!refine_plane(samples_, inlier_, n, &p)) break;
      if (!orient_and_check(&p, min_up, cfg.camera_height_min_m, cfg.camera_height_max_m)) {
        refused = true;
        break;
      }
      best = p;
    }
    best_count = count_inliers(best, samples_, n, tol, inlier_);
    // A floor spans metres; a torso or a thigh seen from above is a plane too, and with no floor
    // in view (nothing but people) it would win. The inliers' box must have a diagonal of at
    // least floor_min_extent_m.
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (int32_t i = 0; i < n; ++i) {
      if (!inlier_[i]) continue;
      for (int k = 0; k < 3; ++k) {
        const float c = samples_[3 * i + k];
        if (c < lo[k]) lo[k] = c;
        if (c > hi[k]) hi[k] = c;
      }
    }
    float diag2 = 0.0f;
    for (int k = 0; k < 3; ++k) diag2 += hi[k] > lo[k] ? (hi[k] - lo[k]) * (hi[k] - lo[k]) : 0.0f;
    const float extent = best_count < needed ? cfg.floor_wide_extent_m : cfg.floor_min_extent_m;
    fitted = !refused && best_count >= wide_needed && diag2 >= extent * extent;
  }
  if (fitted) {
    *floor_ = FloorPlane{best.nx, best.ny, best.nz, best.d, 1, best_count, n, 0};
    r->flags |= kSegFlagFloorFitted;
  } else if (had_plane && floor_->held_frames < cfg.floor_keep_frames) {
    ++floor_->held_frames;
    floor_->inliers = best_count;
    floor_->samples = n;
    r->flags |= kSegFlagFloorHeld;
  } else {
    memset(floor_, 0, sizeof *floor_);
    floor_->samples = n;
    floor_->inliers = best_count;
  }
  r->floor = *floor_;
}

int32_t Segmenter::classify_pixels(const DepthFrame& f) {
  const SegmenterConfig& cfg = *config_;
  const int32_t w = f.width, h = f.height;
  const bool use_floor = floor_->valid != 0;
  const bool use_background = cfg.background_enabled && state_->frames > 0;
  // Signed height above the floor of pixel (u, v) at depth z metres: z·(a·u + b_v) + d.
  const float a = use_floor ? floor_->nx / f.intrinsics.fx : 0.0f;
  const float a0 = use_floor ? -floor_->nx * f.intrinsics.cx / f.intrinsics.fx + floor_->nz : 0.0f;
  int32_t count = 0;
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const BackgroundCell* bg = background_ + size_t(v) * w;
    int32_t* parent = parent_ + size_t(v) * w;
    int32_t* aux = aux_ + size_t(v) * w;
    const float bv = use_floor ? a0 - floor_->ny * (float(v) - f.intrinsics.cy) / f.intrinsics.fy : 0.0f;
    // A pixel the model has never seen without a user on it (someone stood there from the start)
    // is judged by chains along the row from known model pixels, leftwards and rightwards: an
    // unseen reading not nearer than the chain's depth (by more than the tolerance) is background
    // and carries the chain on at its own depth; a nearer one is foreground and leaves the chain
    // as it was; more than kChainGap readings missing in a row break it. Where a person has
    // walked away, the wall revealed behind them continues the surfaces beside it and is
    // background at once, even where a cupboard meets the wall inside that strip. A person beside
    // a learned object at their own depth, across a gap without readings, keeps their pixels.
    // (A person touching such an object continues its surface and can lose those rows.) `aux`
    // holds the rightward chain's verdict until the loop below resets it.
    constexpr int32_t kChainGap = 4;
    const float tol_a = cfg.background_tolerance_mm, tol_b = cfg.background_tolerance_per_m2_mm;
    if (use_background) {
      int32_t chain = 0, gap = 0;
      for (int32_t u = w - 1; u >= 0; --u) {
        const int32_t z = row[u];
        aux[u] = 0;
        if (bg[u].depth_mm != 0) {
          chain = bg[u].depth_mm;
          gap = 0;
        } else if (z == 0) {
          if (++gap > kChainGap) chain = 0;
        } else {
          gap = 0;
          if (chain != 0 && float(z - chain) >= -tolerance_mm(tol_a, tol_b, float(z))) {
            aux[u] = 1;
            chain = z;
          }
        }
      }
    }
    int32_t chain = 0, gap = 0;
    for (int32_t u = 0; u < w; ++u) {
      const uint16_t z = row[u];
      bool keep = z >= cfg.near_mm && z <= cfg.far_mm;
      if (keep && use_floor) {
        const float height_mm = (float(z) * (a * float(u) + bv) + floor_->d * 1000.0f);
        keep = height_mm > tolerance_mm(cfg.floor_margin_mm, cfg.floor_margin_per_m2_mm, float(z));
      }
      if (use_background) {
        const float tol = tolerance_mm(tol_a, tol_b, float(z));
        if (bg[u].depth_mm != 0) {
          chain = bg[u].depth_mm;
          gap = 0;
          if (keep) keep = float(z) - float(bg[u].depth_mm) < -tol;
        } else if (z == 0) {
          if (++gap > kChainGap) chain = 0;
        } else {
          gap = 0;
          const bool left_background = chain != 0 && float(int32_t(z) - chain) >= -tol;
          if (left_background) chain = z;
          if (left_background || aux[u]) keep = false;
        }
      }
      const int32_t i = v * w + u;
      parent[u] = keep ? i : -1;
      aux[u] = 1;
      count += keep;
    }
  }
  return count;
}

static inline int32_t find_root(int32_t* parent, int32_t i) {
  while (parent[i] != i) {  // path halving; union by size keeps depth ≤ log2(W·H)
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

static inline void unite(int32_t* parent, int32_t* size, int32_t a, int32_t b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a == b) return;
  if (size[a] < size[b] || (size[a] == size[b] && b < a)) {
    const int32_t t = a; a = b; b = t;
  }
  parent[b] = a;
  size[a] += size[b];
}

int32_t Segmenter::label_components(const DepthFrame& f, SegmentationResult* r) {
  const SegmenterConfig& cfg = *config_;
  const int32_t w = f.width, h = f.height;
  const float join_per_mm = cfg.join_mm_per_m * 0.001f;
  auto join = [&](int32_t i, int32_t j, int32_t z, int32_t zn) {
    const int32_t zmax = z > zn ? z : zn;
    if (float(z > zn ? z - zn : zn - z) <= cfg.join_mm + join_per_mm * float(zmax)) unite(parent_, aux_, i, j);
  };
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const uint16_t* above = v > 0 ? row - f.stride_px : nullptr;
    for (int32_t u = 0; u < w; ++u) {
      const int32_t i = v * w + u;
      if (parent_[i] < 0) continue;
      const int32_t z = row[u];
      if (u > 0 && parent_[i - 1] >= 0) {
        const int32_t zn = row[u - 1];
        const int32_t zmax = z > zn ? z : zn;
        if (float(z > zn ? z - zn : zn - z) <= cfg.join_mm + join_per_mm * float(zmax)) unite(parent_, aux_, i, i - 1);
      }
      if (above && parent_[i - w] >= 0) {
        const int32_t zn = above[u];
        const int32_t zmax = z > zn ? z : zn;
        if (float(z > zn ? z - zn : zn - z) <= cfg.join_mm + join_per_mm * float(zmax)) unite(parent_, aux_, i, i - w);
      }
      // Sensor dropouts (no reading) cut thin limbs into pieces: bridge a one-pixel hole to the
      // left and above, and join the upper diagonals.
      if (u > 1 && row[u - 1] == 0 && parent_[i - 2] >= 0) join(i, i - 2, z, row[u - 2]);
      if (v > 1 && above[u] == 0 && parent_[i - 2 * w] >= 0) join(i, i - 2 * w, z, above[u - f.stride_px]);
      if (above && u > 0 && parent_[i - w - 1] >= 0) join(i, i - w - 1, z, above[u - 1]);
      if (above && u + 1 < w && parent_[i - w + 1] >= 0) join(i, i - w + 1, z, above[u + 1]);
    }
  }
  // Keep the kMaxCandidates largest components (replace-smallest keeps it independent of
  // raster order); every other root is marked −1.
  const int32_t total = w * h;
  int32_t kept = 0, components = 0;
  for (int32_t i = 0; i < total; ++i) {
    if (parent_[i] != i) continue;
    const int32_t size = aux_[i];
    aux_[i] = -1;
    if (size < cfg.min_component_pixels) continue;
    ++components;
    if (kept < kMaxCandidates) {
      candidates_[kept++].root = i;
      candidates_[kept - 1].pixels = size;
      continue;
    }
    r->flags |= kSegFlagCandidatesTruncated;
    int32_t smallest = 0;
    for (int32_t k = 1; k < kept; ++k)
      if (candidates_[k].pixels < candidates_[smallest].pixels) smallest = k;
    if (size > candidates_[smallest].pixels) {
      candidates_[smallest].root = i;
      candidates_[smallest].pixels = size;
    }
  }
  r->component_count = components;
  for (int32_t k = 0; k < kept; ++k) {
    Candidate& c = candidates_[k];
    aux_[c.root] = k;
    clear_stats(c);
    c.hidden_edge = 0;
    c.hidden_below = 0;
    c.user = 0;
    c.owner = k;
  }
  // Statistics. With a floor, x_min/x_max run along the floor's horizontal axis nearest camera x
  // and `top` is the height above the floor; without one, camera x and the y extent.
  const bool use_floor = floor_->valid != 0;
  float hx = 1.0f, hy = 0.0f, hz = 0.0f;
  if (use_floor) {
    const float dot = floor_->nx;
    hx = 1.0f - dot * floor_->nx; hy = -dot * floor_->ny; hz = -dot * floor_->nz;
    const float len = sqrtf(hx * hx + hy * hy + hz * hz);
    if (len > 1e-3f) { hx /= len; hy /= len; hz /= len; } else { hx = 1.0f; hy = hz = 0.0f; }
  }
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  const bool count_hidden = cfg.hidden_area_fraction > 0.0f;
  const int32_t gap = int32_t(cfg.hidden_gap_mm);
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    for (int32_t u = 0; u < w; ++u) {
      const int32_t i = v * w + u;
      if (parent_[i] < 0) continue;
      const int32_t root = find_root(parent_, i);
      parent_[i] = root;
      const int32_t k = aux_[root];
      if (k < 0) continue;
      Candidate& c = candidates_[k];
      if (count_hidden) {
        // Per direction (left, right, up, down) the first reading within kHiddenReach pixels
        // (an occluding edge casts a shadow without readings): nearer by more than the gap?
        constexpr int32_t kHiddenReach = 4;
        const int32_t zi = int32_t(row[u]) - gap;
        const int32_t du[4] = {-1, 1, 0, 0}, dv[4] = {0, 0, -1, 1};
        for (int32_t dir = 0; dir < 4; ++dir) {
          int32_t uu = u, vv = v;
          for (int32_t step = 0; step < kHiddenReach; ++step) {
            uu += du[dir];
            vv += dv[dir];
            if (uu < 0 || uu >= w || vv < 0 || vv >= h) break;
            const uint16_t zn = f.depth_mm[size_t(vv) * f.stride_px + uu];
            if (zn == 0) continue;
            c.hidden_edge += int32_t(zn) < zi;
            if (dir == 3) c.hidden_below += int32_t(zn) < zi;
            break;
          }
        }
      }
      const float z = float(row[u]) * 0.001f;
      const float x = (float(u) - f.intrinsics.cx) * z * inv_fx;
      const float y = -(float(v) - f.intrinsics.cy) * z * inv_fy;
      add_point(c, u, v, x, y, z, x * hx + y * hy + z * hz);
      if (use_floor) add_height(c, floor_->nx * x + floor_->ny * y + floor_->nz * z + floor_->d);
    }
  }
  if (!use_floor)
    for (int32_t k = 0; k < kept; ++k) candidates_[k].top = candidates_[k].y_max - candidates_[k].y_min;
  // Components cut by the top border (the only ones whose fill matters, passes_person_test):
  // pixels of the image box hidden by something in front count as filled, since what is behind
  // them is unknown. At most kMaxCandidates boxes, each within the frame.
  for (int32_t k = 0; k < kept; ++k) {
    Candidate& c = candidates_[k];
    c.occluded = c.hull = c.hull_filled = c.gap_rows = 0;
    c.cut_pixels = c.v_min == 0 ? c.pixels : 0;
    c.cut_u_min = c.v_min == 0 ? c.u_min : int16_t(32767);
    c.cut_u_max = c.v_min == 0 ? c.u_max : int16_t(-1);
    if (!use_floor || cfg.cut_max_fill <= 0.0f || c.v_min > 0 || c.pixels == 0) continue;
    const int32_t front = int32_t(c.z_min * 1000.0f) - int32_t(cfg.join_mm);
    for (int32_t v = c.v_min; v <= c.v_max; ++v) {
      const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
      for (int32_t u = c.u_min; u <= c.u_max; ++u)
        c.occluded += row[u] != 0 && int32_t(row[u]) < front;
    }
    measure_hull(f, &c);
  }
  return kept;
}

template <class Visit>
void Segmenter::for_each_pixel_of(const DepthFrame& f, int32_t owner, Visit&& visit) const {
  const Candidate& c = candidates_[owner];
  for (int32_t v = c.v_min; v <= c.v_max; ++v) {
    const int32_t* parent = parent_ + size_t(v) * f.width;
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    for (int32_t u = c.u_min; u <= c.u_max; ++u)
      if (owned(parent[u], nullptr, owner)) visit(u, v, v * f.width + u, row[u]);
  }
}

// The component's row-wise convex hull: per image row, the span between the convex chain of its
// leftmost pixels and the concave chain of its rightmost ones (Andrew's monotone chain with the
// row as abscissa). hull = pixels in those spans; hull_filled = the component's own pixels plus
// the readings in the spans nearer than its nearest point less join_mm (hidden by something in
// front: unknown, counted as filled). A solid box or cylinder fills its hull whatever the camera's
// roll; two legs leave the gap between them. Work: 3 passes over the candidate's image box.
void Segmenter::measure_hull(const DepthFrame& f, Candidate* cand, int32_t owner) {
  Candidate& c = *cand;
  const int32_t w = f.width;
  const int32_t rows = c.v_max - c.v_min + 1;
  int16_t* left = hull_rows_;             // leftmost u per row (−1: none)
  int16_t* right = hull_rows_ + rows;     // rightmost u per row
  int16_t* lchain = hull_rows_ + 2 * rows;// row offsets of the left chain's vertices
  int16_t* rchain = hull_rows_ + 3 * rows;
  // Rows with a gap between two runs of the component's pixels, at least 2 pixels wide, seen
  // through (no reading nearer than the component's nearest point less join_mm: nothing in front
  // hides it; pixels without a reading allowed, at least one with a reading): the space between
  // two legs (header, cut_gap_min_share). Counted for every top-border component, rule on or off.
  const int32_t front = int32_t(c.z_min * 1000.0f) - int32_t(config_->join_mm);
  c.gap_rows = 0;
  for (int32_t v = c.v_min; v <= c.v_max; ++v) {
    const int32_t* parent = parent_ + size_t(v) * w;
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    int16_t lo = -1, hi = -1;
    int32_t gap = 0, seen = 0;  // since the last own pixel: gap pixels, of them with a reading
    bool through = true, two_runs = false;
    for (int32_t u = c.u_min; u <= c.u_max; ++u) {
      const int32_t p = parent[u];
      if (!owned(p, cand, owner)) {
        ++gap;
        seen += row[u] != 0;
        through = through && (row[u] == 0 || int32_t(row[u]) >= front);
        continue;
      }
      if (lo >= 0 && gap >= 2 && seen > 0 && through) two_runs = true;
      gap = seen = 0;
      through = true;
      if (lo < 0) lo = int16_t(u);
      hi = int16_t(u);
    }
    c.gap_rows += two_runs;
    left[v - c.v_min] = lo;
    right[v - c.v_min] = hi;
  }
    // Chains: left = lower convex hull of (row, left), right = upper hull of (row, right).
  int32_t nl = 0, nr = 0;
  for (int32_t r = 0; r < rows; ++r) {
    if (left[r] < 0) continue;
    while (nl >= 2) {
      const int32_t a = lchain[nl - 2], b = lchain[nl - 1];
      // cross((b − a), (r − a)) in (row, u): pop b when it is not strictly left of a→r's chain.
      const int32_t cross = (b - a) * (left[r] - left[a]) - (left[b] - left[a]) * (r - a);
      if (cross <= 0) --nl; else break;
    }
    lchain[nl++] = int16_t(r);
    while (nr >= 2) {
      const int32_t a = rchain[nr - 2], b = rchain[nr - 1];
      const int32_t cross = (b - a) * (right[r] - right[a]) - (right[b] - right[a]) * (r - a);
      if (cross >= 0) --nr; else break;
    }
    rchain[nr++] = int16_t(r);
  }
  c.hull = c.hull_filled = 0;
  if (nl == 0) return;
  int32_t li = 0, ri = 0;
  for (int32_t r = lchain[0]; r <= lchain[nl - 1]; ++r) {
    while (li + 1 < nl && lchain[li + 1] < r) ++li;
    while (ri + 1 < nr && rchain[ri + 1] < r) ++ri;
    float lu = left[lchain[li]], ru = right[rchain[ri]];
    if (li + 1 < nl && lchain[li + 1] > lchain[li]) {
      const float t = float(r - lchain[li]) / float(lchain[li + 1] - lchain[li]);
      lu = float(left[lchain[li]]) + t * float(left[lchain[li + 1]] - left[lchain[li]]);
    }
    if (ri + 1 < nr && rchain[ri + 1] > rchain[ri]) {
      const float t = float(r - rchain[ri]) / float(rchain[ri + 1] - rchain[ri]);
      ru = float(right[rchain[ri]]) + t * float(right[rchain[ri + 1]] - right[rchain[ri]]);
    }
    const int32_t u0 = int32_t(ceilf(lu - 1e-3f)), u1 = int32_t(floorf(ru + 1e-3f));
    const int32_t v = c.v_min + r;
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const int32_t* parent = parent_ + size_t(v) * w;
    for (int32_t u = u0; u <= u1; ++u) {
      ++c.hull;
      const int32_t p = parent[u];
      const bool own = owned(p, cand, owner);
      c.hull_filled += own || (row[u] != 0 && int32_t(row[u]) < front);
    }
  }
}

// Cut by the left or right border (header, cut_side_area_fraction): touches either side but not
// the top border (whose height would be out of view), a floor is known, as high as a person and
// holds the given fraction of the person area `need`. The width test is the caller's.
bool Segmenter::cut_by_side(const DepthFrame& f, const Candidate& c, float need) const {
  const SegmenterConfig& cfg = *config_;
  return cfg.cut_side_area_fraction > 0.0f && floor_->valid != 0 && (c.u_min == 0 || c.u_max == f.width - 1) &&
         c.v_min > 0 && c.top >= cfg.min_person_height_m &&
         float(c.pixels) >= cfg.cut_side_area_fraction * need;
}

bool Segmenter::passes_person_test(const DepthFrame& f, const Candidate& c, bool cut, bool short_top) const {
  const SegmenterConfig& cfg = *config_;
  const float z = float(c.sz / c.pixels);
  const float need = cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (z * z);
  if (c.x_max - c.x_min > cfg.max_person_width_m) return false;
  // Cut by the bottom border (the head and shoulders of someone close): part of the area is out
  // of view, the height is not (header, cut_bottom_area_fraction).
  if (cut && cfg.cut_bottom_area_fraction > 0.0f && c.v_max == f.height - 1 && floor_->valid != 0 &&
      c.top >= cfg.min_person_height_m && float(c.pixels) >= cfg.cut_bottom_area_fraction * need)
    return true;
  // Cut by the left or right border: part of the area is out of view, the height is not (header,
  // cut_side_area_fraction).
  if (cut && cut_by_side(f, c, need)) return true;
  // Mostly hidden behind something nearer: the height shows, the area does not (header,
  // hidden_area_fraction).
  if (cut && cfg.hidden_area_fraction > 0.0f && c.hidden_edge >= cfg.hidden_min_edge &&
      c.top >= cfg.min_person_height_m && float(c.pixels) >= cfg.hidden_area_fraction * need)
    return true;
  // Short of the area, only the top-border test may still pass it (header, cut_top_area_fraction).
  const bool area = float(c.pixels) >= need;
  if (!area && !(cut && short_top && cfg.cut_top_area_fraction > 0.0f && float(c.pixels) >= cfg.cut_top_area_fraction * need))
    return false;
  if (area && c.top >= cfg.min_person_height_m) return true;
  // Cut by the top border: the height is out of view (header, cut_max_fill).
  if (!cut || cfg.cut_max_fill <= 0.0f || c.v_min > 0 || floor_->valid == 0) return false;
  // Off the floor only when something nearer hides the lower part (header, cut_hidden_floor_contact_m).
  if (c.bottom > cfg.cut_floor_contact_m &&
      !(cfg.cut_hidden_floor_contact_m > 0.0f && c.bottom <= cfg.cut_hidden_floor_contact_m &&
        c.hidden_below >= cfg.hidden_min_edge))
    return false;
  // A union: over the columns of its pieces cut by the border only (header, cut_fill_border_columns).
  const bool pieces = cfg.cut_fill_border_columns != 0 && c.cut_u_max >= c.cut_u_min && c.cut_pixels < c.pixels;
  const int32_t cols = pieces ? c.cut_u_max - c.cut_u_min + 1 : c.u_max - c.u_min + 1;
  const float box = float(cols) * float(c.v_max - c.v_min + 1);
  const float filled = float((pieces ? c.cut_pixels : c.pixels) + c.occluded);
  if (filled <= cfg.cut_max_fill * box) return true;
  // The hull only where nothing in front cuts the silhouette: an object seen partly behind legs
  // takes their outline (header, cut_solidity_max_hidden).
  if (c.hull > 0 && float(c.hull_filled) <= cfg.cut_max_solidity * float(c.hull) &&
      float(c.occluded) <= cfg.cut_solidity_max_hidden * float(c.pixels))
    return true;
  // Two legs apart in enough rows (header, cut_gap_min_share).
  return cfg.cut_gap_min_share > 0.0f && float(c.gap_rows) >= cfg.cut_gap_min_share * float(c.v_max - c.v_min + 1) &&
         filled <= cfg.cut_gap_max_fill * box;
}

void Segmenter::merge_fragments(const DepthFrame& f, int32_t n) {
  const SegmenterConfig& cfg = *config_;
  if (cfg.fragment_join_mm <= 0.0f || n < 2) return;
  // Which candidates touch (4-neighbours within fragment_join_mm): one pass over the image.
  uint64_t touches[kMaxCandidates] = {};
  // And which hide part of which (a 4-neighbour nearer by more than fragment_join_mm, beyond a
  // depth jump): bit m of hides[k] when k is in front of m.
  uint64_t hides[kMaxCandidates] = {};
  const int32_t w = f.width;
  const int32_t join = int32_t(cfg.fragment_join_mm);
  const bool use_floor = floor_->valid != 0;
  const bool hidden_legs_on = cfg.hidden_area_fraction > 0.0f && use_floor && cfg.hidden_legs_radius_m > 0.0f;
  for (int32_t v = 0; v < f.height; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const int32_t* parent = parent_ + size_t(v) * w;
    for (int32_t u = 0; u < w; ++u) {
      if (parent[u] < 0) continue;
      const int32_t k = aux_[parent[u]];
      if (k < 0) continue;
      if (u + 1 < w && parent[u + 1] >= 0) {
        const int32_t m = aux_[parent[u + 1]];
        const int32_t dz = int32_t(row[u]) - int32_t(row[u + 1]);
        if (m >= 0 && m != k && dz <= join && dz >= -join) {
          touches[k] |= uint64_t(1) << m;
          touches[m] |= uint64_t(1) << k;
        }
        if (hidden_legs_on && m >= 0 && m != k && dz < -join) hides[k] |= uint64_t(1) << m;
        if (hidden_legs_on && m >= 0 && m != k && dz > join) hides[m] |= uint64_t(1) << k;
      }
      if (v + 1 < f.height && parent[u + w] >= 0) {
        const int32_t m = aux_[parent[u + w]];
        const int32_t dz = int32_t(row[u]) - int32_t(row[u + f.stride_px]);
        if (m >= 0 && m != k && dz <= join && dz >= -join) {
          touches[k] |= uint64_t(1) << m;
          touches[m] |= uint64_t(1) << k;
        }
        if (hidden_legs_on && m >= 0 && m != k && dz < -join) hides[k] |= uint64_t(1) << m;
        if (hidden_legs_on && m >= 0 && m != k && dz > join) hides[m] |= uint64_t(1) << k;
      }
    }
  }
  bool person[kMaxCandidates];
  // Pieces that pass only as cut by the border are fragments here: they may still join the rest of
  // their body.
  bool full[kMaxCandidates];  // with the relaxations for border cuts
  for (int32_t k = 0; k < n; ++k) {
    person[k] = passes_person_test(f, candidates_[k], false);
    full[k] = person[k] || passes_person_test(f, candidates_[k], true);
  }
  // Passes only as someone mostly hidden (header, hidden_area_fraction).
  bool hidden_only[kMaxCandidates];
  for (int32_t k = 0; k < n; ++k)
    hidden_only[k] = full[k] && !person[k] && candidates_[k].hidden_edge >= cfg.hidden_min_edge;
  auto united = [&](const Candidate& x, const Candidate& y) {
    Candidate c = y;
    add_stats(c, x, use_floor);
    c.occluded += x.occluded;  // each counted in its own box: a lower bound for the union's
    c.hidden_edge += x.hidden_edge;
    c.hidden_below += x.hidden_below;
    c.hull += x.hull;          // each piece's own hull: the union's hull is at least as large,
    c.hull_filled += x.hull_filled;  // so its solidity comes out higher (more box-like), not lower
    c.gap_rows += x.gap_rows;  // each piece's own rows with a gap between two legs
    // The columns of the pieces cut by the top border, widened by a piece that shares columns with
    // them (below them: a shin, the body under raised arms), not by one beside them.
    const bool xc = x.cut_u_max >= x.cut_u_min, yc = y.cut_u_max >= y.cut_u_min;
    if (xc != yc) {
      const Candidate& cut = xc ? x : y;
      const Candidate& other = xc ? y : x;
      c.cut_u_min = cut.cut_u_min;
      c.cut_u_max = cut.cut_u_max;
      c.cut_pixels = cut.cut_pixels;
      if (other.u_min <= cut.cut_u_max && other.u_max >= cut.cut_u_min) {
        if (other.u_min < c.cut_u_min) c.cut_u_min = other.u_min;
        if (other.u_max > c.cut_u_max) c.cut_u_max = other.u_max;
        c.cut_pixels += other.pixels;
      }
    } else if (xc) {
      if (x.cut_u_min < c.cut_u_min) c.cut_u_min = x.cut_u_min;
      if (x.cut_u_max > c.cut_u_max) c.cut_u_max = x.cut_u_max;
      c.cut_pixels += x.cut_pixels;
    }
    return c;
  };
  // A fragment joins the nearest touching (or, within fragment_pair_radius_m, not touching)
  // candidate with which it forms a person: a body cut in two by a depth jump or by someone in
  // front (both pieces may pass on their own), or a piece of a body that passes.
  const bool hidden_on = cfg.hidden_area_fraction > 0.0f;
  float radius = cfg.fragment_radius_m > cfg.hidden_pair_radius_m || !hidden_on ? cfg.fragment_radius_m
                                                                              : cfg.hidden_pair_radius_m;
  if (cfg.legs_radius_m > radius) radius = cfg.legs_radius_m;
  if (hidden_legs_on && cfg.hidden_legs_radius_m > radius) radius = cfg.hidden_legs_radius_m;
  for (int32_t k = 0; k < n; ++k) {
    if (candidates_[k].pixels == 0) continue;
    Candidate& frag = candidates_[k];
    int32_t best = -1;
    float best_d2 = radius * radius;
    for (int32_t m = 0; m < n; ++m) {
      // touches[k] holds k itself once something merged into k.
      if (m == k || candidates_[m].pixels == 0) continue;
      const bool touching = (touches[k] >> m) & 1u;
      const Candidate& body = candidates_[m];
      float d[3] = {float(frag.sx / frag.pixels - body.sx / body.pixels), float(frag.sy / frag.pixels - body.sy / body.pixels),
                    float(frag.sz / frag.pixels - body.sz / body.pixels)};
      if (use_floor) {  // along the floor: drop the vertical part
        const float up = d[0] * floor_->nx + d[1] * floor_->ny + d[2] * floor_->nz;
        d[0] -= up * floor_->nx; d[1] -= up * floor_->ny; d[2] -= up * floor_->nz;
      } else {
        d[1] = 0.0f;
      }
      const float d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      // Pieces of someone hidden behind a nearer body lie on either side of it: two pieces that
      // each pass only as hidden join within hidden_pair_radius_m.
      // A piece that passes only as hidden takes another one, or a smaller hidden piece that
      // does not pass at all (a leg below a head).
      const bool both_hidden = hidden_on && frag.hidden_edge >= cfg.hidden_min_edge &&
                               body.hidden_edge >= cfg.hidden_min_edge &&
                               ((hidden_only[k] && hidden_only[m]) ||
                                (hidden_only[m] && !full[k] && frag.pixels <= body.pixels) ||
                                (hidden_only[k] && !full[m] && body.pixels <= frag.pixels));
      // Legs below a body that does not reach the floor (header, legs_radius_m): the piece stands
      // on the floor and does not pass alone, the body passes; the piece is lower in height and
      // in the image, shares columns with it and has at most twice its pixels.
      const int32_t cols_shared = (frag.u_max < body.u_max ? frag.u_max : body.u_max) -
                                  (frag.u_min > body.u_min ? frag.u_min : body.u_min) + 1;
      const bool legs_below = cfg.legs_radius_m > 0.0f && use_floor && person[m] && !full[k] &&
                              body.bottom > cfg.cut_floor_contact_m && frag.bottom <= cfg.cut_floor_contact_m &&
                              frag.top < body.top && frag.v_min > body.v_min && cols_shared > 0 &&
                              frag.pixels <= 2 * body.pixels && d2 <= cfg.legs_radius_m * cfg.legs_radius_m;
      // The legs of someone partly hidden (header, hidden_legs_radius_m): both pieces have hidden
      // edges, the piece stands on the floor and does not pass, the other passes; the piece is lower
      // in height and in the image and reaches up to within hidden_legs_max_gap_m of the other's
      // lowest point.
      const bool hidden_legs = hidden_legs_on && !full[k] && full[m] && frag.hidden_edge >= cfg.hidden_min_edge &&
                               body.hidden_edge >= cfg.hidden_min_edge && frag.bottom <= cfg.cut_floor_contact_m &&
                               body.bottom > cfg.cut_floor_contact_m && frag.top < body.top && frag.v_min > body.v_min &&
                               frag.top + cfg.hidden_legs_max_gap_m >= body.bottom && !((hides[k] >> m) & 1u) &&
                               float(frag.pixels) <= cfg.hidden_legs_max_ratio * float(body.pixels) &&
                               d2 <= cfg.hidden_legs_radius_m * cfg.hidden_legs_radius_m;
      const bool close = d2 <= cfg.fragment_pair_radius_m * cfg.fragment_pair_radius_m ||
                         (both_hidden && d2 <= cfg.hidden_pair_radius_m * cfg.hidden_pair_radius_m) || legs_below ||
                         hidden_legs;
      if (d2 > cfg.fragment_radius_m * cfg.fragment_radius_m && !both_hidden && !legs_below && !hidden_legs) continue;
      // Pieces that do not touch (a person cut in two by someone standing in front) join only
      // when closer along the floor than two people can stand.
      if (!touching && !close) continue;
      // Two pieces of one body that each pass (a torso over its legs, an arm in front of the
      // legs): the smaller joins.
      if (person[k]) {
        if (!person[m] || candidates_[m].pixels < candidates_[k].pixels) continue;
        // Stacked in the image (same columns, little row overlap), or closer along the floor than
        // two people can stand; unlike two people side by side or one behind the other.
        const Candidate& a = candidates_[k];
        const Candidate& b = candidates_[m];
        const int32_t cols = (a.u_max < b.u_max ? a.u_max : b.u_max) - (a.u_min > b.u_min ? a.u_min : b.u_min) + 1;
        const int32_t rows = (a.v_max < b.v_max ? a.v_max : b.v_max) - (a.v_min > b.v_min ? a.v_min : b.v_min) + 1;
        const int32_t narrow = (a.u_max - a.u_min < b.u_max - b.u_min ? a.u_max - a.u_min : b.u_max - b.u_min) + 1;
        const int32_t short_rows = (a.v_max - a.v_min < b.v_max - b.v_min ? a.v_max - a.v_min : b.v_max - b.v_min) + 1;
        const bool stacked = 2 * cols >= narrow && 10 * rows <= 6 * short_rows;
        if (!stacked && !close) continue;
      }
      // Neither passes alone: the smaller piece must be a real share of the union, or a hand
      // reaching over a box would lend the box its height.
      if (!full[k] && !full[m]) {
        const int32_t small = frag.pixels < body.pixels ? frag.pixels : body.pixels;
        if (float(small) < cfg.fragment_min_share * float(frag.pixels + body.pixels)) continue;
      }
      if (d2 <= best_d2 && passes_person_test(f, united(frag, body))) { best_d2 = d2; best = m; }
    }
    if (best < 0) continue;
    candidates_[best] = united(frag, candidates_[best]);
    hidden_only[best] = candidates_[best].hidden_edge >= cfg.hidden_min_edge && !passes_person_test(f, candidates_[best], false);
    person[best] = full[best] = true;
    touches[best] |= touches[k];
    hides[best] |= hides[k];
    for (int32_t j = 0; j < n; ++j)
      if ((hides[j] >> k) & 1u) hides[j] |= uint64_t(1) << best;
    frag.owner = best;
    frag.pixels = 0;  // no longer a component of its own
  }
  // Owners of owners (a candidate merged into one that merged later) resolve to the last.
  for (int32_t k = 0; k < n; ++k)
    for (int32_t hop = 0; hop < kMaxCandidates && candidates_[candidates_[k].owner].owner != candidates_[k].owner; ++hop)
      candidates_[k].owner = candidates_[candidates_[k].owner].owner;
}

// A component that passes only as someone mostly hidden (too small otherwise, hidden edges, high
// enough) while its image box overlaps a user's (or a component's about to be one) and it is nearer
// than that user: it is not hidden by
// that user but in front of them, and what is in front of a body and overlapping it in the image is
// mostly that body's own arm or hand cut off by a depth jump (on seeds 15-18: 4 false users). Someone
// hidden behind a user is farther than the user.
bool Segmenter::in_front_of_a_user(const DepthFrame& f, int32_t n, int32_t k, const float* cz, const bool* strict) const {
  const SegmenterConfig& cfg = *config_;
  const Candidate& c = candidates_[k];
  if (cfg.hidden_area_fraction <= 0.0f || c.hidden_edge < cfg.hidden_min_edge) return false;
  const float need = cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (cz[k] * cz[k]);
  if (float(c.pixels) >= need || passes_person_test(f, c, false)) return false;
  // Passing as cut by the bottom border (head and shoulders of someone close) is another matter.
  if (cfg.cut_bottom_area_fraction > 0.0f && c.v_max == f.height - 1 && floor_->valid != 0 &&
      c.top >= cfg.min_person_height_m && float(c.pixels) >= cfg.cut_bottom_area_fraction * need)
    return false;
  // So is passing as cut by the left or right border (someone walking out of view).
  if (cut_by_side(f, c, need)) return false;
  for (int32_t m = 0; m < n; ++m) {
    const Candidate& u = candidates_[m];
    if (m == k || (u.user == 0 && !strict[m]) || u.pixels == 0 || cz[m] <= cz[k]) continue;
    if (u.u_max < c.u_min || c.u_max < u.u_min || u.v_max < c.v_min || c.v_max < u.v_min) continue;
    return true;
  }
  return false;
}

// The user (candidate index) that a component about to become a new user belongs to, or −1: a
// larger user, nearer, whose image box (grown by 2 pixels) holds the component's and whose centroid
// is within absorb_radius_m along the floor, or, for a component without a person's area that
// reaches higher than the user, starts above its top row and shares its columns, within
// head_radius_m (header). The nearest such user. Work: one pass over the candidates.
int32_t Segmenter::absorbing_user(const DepthFrame& f, int32_t n, int32_t k, const float* cx, const float* cy,
                                  const float* cz) const {
  const SegmenterConfig& cfg = *config_;
  if (cfg.absorb_radius_m <= 0.0f && cfg.head_radius_m <= 0.0f) return -1;
  const Candidate& c = candidates_[k];
  const bool use_floor = floor_->valid != 0;
  // A piece without a person's area (it passes as hidden or cut) may be the top of a user's body
  // (header, head_radius_m).
  const bool small = float(c.pixels) < cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (cz[k] * cz[k]);
  // Such a piece cut by the top border (with cut_top_area_fraction it may pass that way) beside a
  // larger user cut there too is mostly that user's other leg, a step nearer or farther (header).
  const bool leg_piece = cfg.cut_top_area_fraction > 0.0f && cfg.legs_radius_m > 0.0f && small && c.v_min == 0;
  int32_t best = -1;
  float r = cfg.absorb_radius_m > cfg.head_radius_m ? cfg.absorb_radius_m : cfg.head_radius_m;
  if (leg_piece && cfg.legs_radius_m > r) r = cfg.legs_radius_m;
  float best_d2 = r * r;
  for (int32_t m = 0; m < n; ++m) {
    const Candidate& u = candidates_[m];
    if (m == k || u.user == 0 || u.pixels <= c.pixels) continue;
    const bool nearer = cz[m] < cz[k];
    const bool inside = nearer && cfg.absorb_radius_m > 0.0f && c.u_min >= u.u_min - 2 && c.u_max <= u.u_max + 2 &&
                        c.v_min >= u.v_min - 2 && c.v_max <= u.v_max + 2;
    const bool head = nearer && cfg.head_radius_m > 0.0f && small && c.top > u.top && c.v_min < u.v_min &&
                      c.u_min <= u.u_max && u.u_min <= c.u_max;
    const bool leg = leg_piece && u.v_min == 0;
    if (!inside && !head && !leg) continue;
    float d[3] = {cx[k] - cx[m], cy[k] - cy[m], cz[k] - cz[m]};
    if (use_floor) {
      const float up = d[0] * floor_->nx + d[1] * floor_->ny + d[2] * floor_->nz;
      d[0] -= up * floor_->nx; d[1] -= up * floor_->ny; d[2] -= up * floor_->nz;
    } else {
      d[1] = 0.0f;
    }
    const float d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    float lim = inside && cfg.absorb_radius_m > (head ? cfg.head_radius_m : 0.0f) ? cfg.absorb_radius_m
                                                                                   : (head ? cfg.head_radius_m : 0.0f);
    if (leg && cfg.legs_radius_m > lim) lim = cfg.legs_radius_m;
    if (d2 <= lim * lim && d2 <= best_d2) { best_d2 = d2; best = m; }
  }
  return best;
}

// A person and a box as one component (header, box_split_height_m): the component's pixels binned
// on the floor in a kSplitCells² grid of box_split_cell_m centred on its centroid (pixels outside
// the grid stay). Cells whose highest point is lower than box_split_height_m are low (cells
// reaching the top image row never); the lid is the band of two kLidBins bins of cell tops holding
// the most low-cell pixels. The lid cells' pixels are dropped (marked −1 in parent_, so they are
// labelled background) when they stand on the floor, make at least box_split_min_share of the
// component, their centroid lies at least box_split_min_dist_m from the rest's along the floor and
// the rest passes the person test; the candidate's statistics become the rest's (the hidden-edge,
// occlusion and hull counts are kept). Returns 1 then; 2 when the lid is not dropped but holds at
// least box_reject_min_share of the component (no user); else 0. Work: at most four passes over
// the candidate's image box.
int32_t Segmenter::split_box(const DepthFrame& f, int32_t k, bool low_outline) {
  const SegmenterConfig& cfg = *config_;
  if (cfg.box_split_height_m <= 0.0f || floor_->valid == 0) return 0;
  Candidate& c = candidates_[k];
  // Not for components cut by the top border: the legs of someone seen from close show no top
  // and look like a lid in the cells below the border.
  if (c.pixels == 0 || (c.top < cfg.box_split_height_m && !low_outline) || c.v_min == 0) return 0;
  if (c.bottom > cfg.cut_floor_contact_m) return 0;  // nothing of it stands on the floor
  constexpr int32_t kSplitCells = FloorGrid::kCells;
  float cell_top[kSplitCells * kSplitCells];
  for (int32_t i = 0; i < kSplitCells * kSplitCells; ++i) cell_top[i] = -1e30f;
  FloorGrid grid;
  if (!grid.init_at(*floor_, f.intrinsics, c, cfg.box_split_cell_m))
    return 0;
  const float ax = grid.ax, ay = grid.ay, az = grid.az, bx = grid.bx, by = grid.by, bz = grid.bz;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  // visit(u, v, pixel index, depth mm, cell or -1, height above the floor) for every pixel of the
  // component, in raster order within its image box.
  auto for_each_pixel = [&](auto&& visit) {
    for_each_pixel_of(f, k, [&](int32_t u, int32_t v, int32_t i, uint16_t z_mm) {
      float up;
      const int32_t cell = grid.cell_of(u, v, z_mm, &up);
      visit(u, v, i, z_mm, cell, up);
    });
  };
  for_each_pixel([&](int32_t, int32_t v, int32_t, uint16_t, int32_t cell, float up) {
    // A cell reaching the top image row has its top out of view (legs cut by the border reach
    // the same height in every cell, like a lid): never dropped.
    if (cell >= 0 && (up > cell_top[cell] || v == 0)) cell_top[cell] = v == 0 ? 1e30f : up;
  });
  // The lid: a box's or cylinder's cells all reach the same height (its top face, or the top edge
  // of its faces), a body's low cells (feet, a leg, a hand) do not. Pixel-weighted histogram of
  // the low cells' tops in kLidBins bins below box_split_height_m; the lid is the pair of
  // neighbouring bins with the most pixels, and only cells whose top lies in it are dropped.
  constexpr int32_t kLidBins = 32;
  int32_t lid_hist[kLidBins] = {};
  const float bin_scale = float(kLidBins) / cfg.box_split_height_m;
  for_each_pixel([&](int32_t, int32_t, int32_t, uint16_t, int32_t cell, float) {
    if (cell < 0 || cell_top[cell] >= cfg.box_split_height_m || cell_top[cell] < 0.0f) return;
    const int32_t bin = int32_t(cell_top[cell] * bin_scale);
    ++lid_hist[bin < kLidBins ? bin : kLidBins - 1];
  });
  int32_t lid_bin = 0;
  for (int32_t b = 1; b + 1 < kLidBins; ++b)
    if (lid_hist[b] + lid_hist[b + 1] > lid_hist[lid_bin] + lid_hist[lid_bin + 1]) lid_bin = b;
  const float lid_lo = float(lid_bin) / bin_scale, lid_hi = float(lid_bin + 2) / bin_scale;
  auto in_lid = [&](int32_t cell) {
    return cell >= 0 && cell_top[cell] >= lid_lo && cell_top[cell] < lid_hi && cell_top[cell] < cfg.box_split_height_m;
  };
  // The rest's statistics, and the dropped part's count and lowest point.
  Candidate rest = c;
  clear_stats(rest);
  int32_t dropped = 0;
  float dropped_bottom = 1e30f;
  for_each_pixel([&](int32_t u, int32_t v, int32_t, uint16_t z_mm, int32_t cell, float up) {
    if (in_lid(cell)) {
      ++dropped;
      if (up < dropped_bottom) dropped_bottom = up;
      return;
    }
    const float z = float(z_mm) * 0.001f;
    const float x = (float(u) - f.intrinsics.cx) * z * inv_fx;
    const float y = -(float(v) - f.intrinsics.cy) * z * inv_fy;
    add_point(rest, u, v, x, y, z, x * ax + y * ay + z * az);
    add_height(rest, up);
  });
  if (dropped == 0 || rest.pixels == 0 || dropped_bottom > cfg.cut_floor_contact_m) return 0;
  const bool rest_passes = passes_person_test(f, rest);
  // Centroid distance along the floor between the dropped part and the rest.
  const float dx = float((c.sx - rest.sx) / dropped - rest.sx / rest.pixels);
  const float dy = float((c.sy - rest.sy) / dropped - rest.sy / rest.pixels);
  const float dz = float((c.sz - rest.sz) / dropped - rest.sz / rest.pixels);
  const float da = dx * ax + dy * ay + dz * az, db = dx * bx + dy * by + dz * bz;
  const bool apart = da * da + db * db >= cfg.box_split_min_dist_m * cfg.box_split_min_dist_m;
  // A low component that passed only by its outline (header, low_max_solidity) holding a box's lid
  // apart from the rest: the outline is that of a box and something beside it, not a body's. A lid
  // under the rest is its own back (someone bent over), which the reject below would take for a
  // box's: not for these.
  const bool lid_apart = apart && float(dropped) >= cfg.box_split_min_share * float(c.pixels);
  if (low_outline && !(rest_passes && lid_apart)) return lid_apart ? 2 : 0;
  if (!rest_passes || !apart || float(dropped) < cfg.box_split_min_share * float(c.pixels)) {
    // Not a box beside a person: a lid holding box_reject_min_share of the component is a box with
    // a hand or arm over it (header).
    const bool lid = cfg.box_reject_min_share > 0.0f && float(dropped) >= cfg.box_reject_min_share * float(c.pixels);
    return lid ? 2 : 0;
  }
  for_each_pixel([&](int32_t, int32_t, int32_t i, uint16_t, int32_t cell, float) {
    if (in_lid(cell)) parent_[i] = -1;
  });
  c = rest;
  return 1;
}

// Someone low over the floor (header, low_max_lid_share): a component with the person area and
// width, standing on the floor, its top in view, at least low_min_height_m but less than
// min_person_height_m high, whose cells on the floor (box_split_cell_m, a kLowCells² grid centred on
// its centroid; pixels outside the grid count as outside the lid) reach many heights: at most
// low_max_lid_share of its pixels lie in cells whose tops fall within the height band (kLowBins
// bins below min_person_height_m, as wide as the depth noise at its mean depth) holding the most
// pixels. A box or cylinder reaches its top in every cell. Returns 1 then. Returns 2 (thirteenth
// pass, low_max_solidity) when at most low_outline_max_lid_share of its pixels lie there and its
// silhouette fills at most low_max_solidity of its row-wise hull (measure_hull over its merged
// pieces): no solid's outline. Returns 3 (fifteenth pass, cut_bottom_low_max_lid_share) for a
// component cut by the bottom border whose lowest point is above cut_floor_contact_m (its feet and
// the floor under them out of view) when at most cut_bottom_low_max_lid_share of its pixels lie in
// that band and at most cut_solidity_max_hidden of its image box is hidden by something nearer; such
// a component gets no other test. Else 0. Work: two passes over the candidate's image box (three
// more for the hull, one for the hidden pixels), 48 × 48 cells (9 KB) and 64 bins on the stack.
int32_t Segmenter::low_person(const DepthFrame& f, int32_t k) {
  const SegmenterConfig& cfg = *config_;
  const Candidate& c = candidates_[k];
  if ((cfg.low_max_lid_share <= 0.0f && cfg.low_max_solidity <= 0.0f && cfg.cut_bottom_low_max_lid_share <= 0.0f) ||
      floor_->valid == 0 || c.pixels == 0 || c.v_min == 0)
    return 0;
  // Cut by the bottom border above the floor (header, cut_bottom_low_max_lid_share): the feet and
  // the floor under them are below the image; only the lid share judges it, with its own cap.
  const bool feet_below = cfg.cut_bottom_low_max_lid_share > 0.0f && c.v_max == f.height - 1 &&
                          c.bottom > cfg.cut_floor_contact_m;
  if (c.top >= cfg.min_person_height_m || c.top < cfg.low_min_height_m || (c.bottom > cfg.cut_floor_contact_m && !feet_below))
    return 0;
  if (c.x_max - c.x_min > cfg.max_person_width_m) return 0;
  const float z = float(c.sz / c.pixels);
  if (float(c.pixels) < cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (z * z)) return 0;
  constexpr int32_t kLowCells = FloorGrid::kCells;
  constexpr int32_t kLowBins = 64;
  float cell_top[kLowCells * kLowCells];
  for (int32_t i = 0; i < kLowCells * kLowCells; ++i) cell_top[i] = -1e30f;
  FloorGrid grid;
  if (!grid.init_at(*floor_, f.intrinsics, c, cfg.box_split_cell_m))
    return 0;
  // pass 0: each cell's top; pass 1: pixel-weighted histogram of the cells' tops.
  int32_t hist[kLowBins] = {};
  const float bin_scale = float(kLowBins) / cfg.min_person_height_m;
  for (int32_t pass = 0; pass < 2; ++pass)
    for_each_pixel_of(f, k, [&](int32_t u, int32_t v, int32_t, uint16_t z_mm) {
      float up;
      const int32_t cell = grid.cell_of(u, v, z_mm, &up);
      if (cell < 0) return;
      float& top = cell_top[cell];
      if (pass == 0) {
        if (up > top) top = up;
      } else if (top >= 0.0f) {
        const int32_t bin = int32_t(top * bin_scale);
        ++hist[bin < kLowBins ? bin : kLowBins - 1];
      }
    });
  // The band widens with the depth noise, which spreads a box's cell tops: 2·(3 cm + 4 mm/m²·z²)
  // (13 cm at 3 m, 22 cm at 4.5 m; with a fixed 5.3 cm band boxes beyond 3 m fell to lid shares of
  // 0.2-0.4, like the people).
  constexpr float kBandM = 0.03f, kBandPerM2 = 0.004f;
  int32_t band = int32_t(2.0f * (kBandM + kBandPerM2 * z * z) * bin_scale + 0.5f);
  if (band < 1) band = 1;
  if (band > kLowBins) band = kLowBins;
  int32_t lid = 0, run = 0;
  for (int32_t b = 0; b < kLowBins; ++b) {
    run += hist[b] - (b >= band ? hist[b - band] : 0);
    if (run > lid) lid = run;
  }
  if (feet_below) {
    if (float(lid) > cfg.cut_bottom_low_max_lid_share * float(c.pixels)) return 0;
    // Not when something nearer hides part of its image box (more than cut_solidity_max_hidden of
    // its pixel count): what is hidden may be the rest of a lid (a box behind someone showed 0.62).
    // One pass over the image box.
    int32_t occluded = 0;
    const int32_t front = int32_t(c.z_min * 1000.0f) - int32_t(cfg.join_mm);
    for (int32_t v = c.v_min; v <= c.v_max; ++v) {
      const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
      for (int32_t u = c.u_min; u <= c.u_max; ++u) occluded += row[u] != 0 && int32_t(row[u]) < front;
    }
    return float(occluded) <= cfg.cut_solidity_max_hidden * float(c.pixels) ? 3 : 0;
  }
  if (cfg.low_max_lid_share > 0.0f && float(lid) <= cfg.low_max_lid_share * float(c.pixels)) return 1;
  // A lid over most cells, but an outline no solid has (header, low_max_solidity): the image of a
  // box or cylinder is convex and fills its row-wise hull. Readings nearer than the component (less
  // join_mm) count as filled, since what they hide is unknown. Three passes over the image box.
  if (cfg.low_max_solidity <= 0.0f || float(lid) > cfg.low_outline_max_lid_share * float(c.pixels)) return 0;
  Candidate outline = c;
  measure_hull(f, &outline, k);
  const bool hollow = outline.hull > 0 && float(outline.hull_filled) <= cfg.low_max_solidity * float(outline.hull);
  return hollow ? 2 : 0;
}

// Two people joined by an arm (header, pair_bridge_max_m): the component's pixels profiled along the
// floor's horizontal axis (FloorGrid's a, the axis of its width) in at most kPairBins bins of at
// least kPairBinM, each with its highest and lowest point. The first run of bridge bins (not empty,
// thin and at least min_person_height_m up) with a standing bin (floor to min_person_height_m) on
// each side is cut in its middle when each side alone passes the person test (no border
// relaxations) and stands on the floor. The pixels beyond the cut (the higher bins) move to a new
// candidate (index n): its root is one of them that is no component's root, and every pixel of
// that side points to it (labels and the later tests read one hop, parent_ → aux_); candidate k
// keeps the rest, its statistics re-measured (its hidden-edge, occlusion and hull counts kept; the
// new one has none). Returns n, or −1 when k is kept whole. Work: three passes over the
// candidate's image box, 64 bins on the stack.
int32_t Segmenter::split_pair(const DepthFrame& f, int32_t n, int32_t k) {
  const SegmenterConfig& cfg = *config_;
  if (cfg.pair_bridge_max_m <= 0.0f || floor_->valid == 0 || n >= kMaxCandidates) return -1;
  Candidate& c = candidates_[k];
  // Also when cut by the top border (someone's head out of view): the height shown there is a lower
  // bound, so the standing bins and the person test of each side only get stricter.
  if (c.pixels == 0 || c.bottom > cfg.cut_floor_contact_m || c.top < cfg.min_person_height_m) return -1;
  FloorGrid grid;
  if (!grid.init_at(*floor_, f.intrinsics, c, cfg.box_split_cell_m))
    return -1;
  const float ax = grid.ax, ay = grid.ay, az = grid.az;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  constexpr int32_t kPairBins = 64;
  constexpr float kPairBinM = 0.05f;
  // x_min/x_max run along the same axis (label_components, merges): the bins cover the extent.
  const float a_lo = c.x_min, extent = c.x_max - c.x_min;
  float bin_m = extent / float(kPairBins - 1);
  if (bin_m < kPairBinM) bin_m = kPairBinM;
  const int32_t bins = int32_t(extent / bin_m) + 1;
  if (bins < 3) return -1;
  // visit(u, v, pixel index, x, y, z, height above the floor, bin) for every pixel of the union.
  auto for_each_pixel = [&](auto&& visit) {
    for_each_pixel_of(f, k, [&](int32_t u, int32_t v, int32_t i, uint16_t z_mm) {
      const float z = float(z_mm) * 0.001f;
      const float x = (float(u) - f.intrinsics.cx) * z * inv_fx;
      const float y = -(float(v) - f.intrinsics.cy) * z * inv_fy;
      const float up = floor_->nx * x + floor_->ny * y + floor_->nz * z + floor_->d;
      int32_t b = int32_t((x * ax + y * ay + z * az - a_lo) / bin_m);
      b = b < 0 ? 0 : b >= bins ? bins - 1 : b;
      visit(u, v, i, x, y, z, up, b);
    });
  };
  float top[kPairBins], low[kPairBins];
  for (int32_t b = 0; b < bins; ++b) { top[b] = -1e30f; low[b] = 1e30f; }
  for_each_pixel([&](int32_t, int32_t, int32_t, float, float, float, float up, int32_t b) {
    if (up > top[b]) top[b] = up;
    if (up < low[b]) low[b] = up;
  });
  // A bridge bin: an arm held out, at least min_person_height_m up and thin. A single body's thin
  // slices (between the legs, a knee, a leg held out) are lower. Not an empty bin: the pieces of a
  // body that merge_fragments joined across someone in front leave empty bins between them.
  auto thin = [&](int32_t b) {
    return top[b] >= low[b] && low[b] >= cfg.min_person_height_m && top[b] - low[b] <= cfg.pair_bridge_max_m;
  };
  // A standing bin: from the floor to min_person_height_m in one slice (legs under a body).
  auto standing = [&](int32_t b) { return low[b] <= cfg.cut_floor_contact_m && top[b] >= cfg.min_person_height_m; };
  // Per bin: is there a standing bin before it (after it)?
  bool left_ok[kPairBins], right_ok[kPairBins];
  bool seen = false;
  for (int32_t b = 0; b < bins; ++b) {
    left_ok[b] = seen;
    seen = seen || standing(b);
  }
  seen = false;
  for (int32_t b = bins - 1; b >= 0; --b) {
    right_ok[b] = seen;
    seen = seen || standing(b);
  }
  int32_t cut = -1;  // first bin beyond the cut
  for (int32_t b = 1; b + 1 < bins && cut < 0;) {
    if (!thin(b)) { ++b; continue; }
    int32_t e = b;
    while (e + 1 < bins && thin(e + 1)) ++e;
    if (e + 1 < bins && left_ok[b] && right_ok[e]) cut = (b + e + 1) / 2;
    b = e + 1;
  }
  if (cut < 0) return -1;
  // Both sides alone.
  Candidate keep = c, moved = c;
  clear_stats(keep);
  clear_stats(moved);
  int32_t root = -1;
  for_each_pixel([&](int32_t u, int32_t v, int32_t i, float x, float y, float z, float up, int32_t b) {
    Candidate& side = b < cut ? keep : moved;
    add_point(side, u, v, x, y, z, x * ax + y * ay + z * az);
    add_height(side, up);
    if (b >= cut && root < 0 && parent_[i] != i) root = i;
  });
  if (root < 0 || keep.pixels == 0 || moved.pixels == 0) return -1;
  if (keep.bottom > cfg.cut_floor_contact_m || moved.bottom > cfg.cut_floor_contact_m) return -1;
  if (!passes_person_test(f, keep, false) || !passes_person_test(f, moved, false)) return -1;
  for_each_pixel([&](int32_t, int32_t, int32_t i, float, float, float, float, int32_t b) {
    if (b >= cut) parent_[i] = root;
  });
  parent_[root] = root;
  aux_[root] = n;
  moved.root = root;
  moved.occluded = moved.hidden_edge = moved.hidden_below = moved.hull = moved.hull_filled = moved.gap_rows = 0;
  moved.cut_pixels = 0;
  moved.cut_u_min = int16_t(32767);
  moved.cut_u_max = int16_t(-1);
  moved.user = 0;
  moved.owner = n;
  candidates_[n] = moved;
  c = keep;
  return n;
}

void Segmenter::assign_users(const DepthFrame& f, int32_t candidate_count, SegmentationResult* r) {
  int32_t n = candidate_count;  // grows when a component is cut in two (split_pair)
  const SegmenterConfig& cfg = *config_;
  merge_fragments(f, n);
  bool strict[kMaxCandidates], relaxed[kMaxCandidates];
  bool outline[kMaxCandidates] = {};  // passes only as low by its outline (low_max_solidity)
  float cx[kMaxCandidates], cy[kMaxCandidates], cz[kMaxCandidates];
  const float focal2 = f.intrinsics.fx * f.intrinsics.fy;
  for (int32_t k = 0; k < n; ++k) {
    const Candidate& c = candidates_[k];
    if (c.pixels == 0) {  // merged into another candidate
      strict[k] = relaxed[k] = false;
      cx[k] = cy[k] = cz[k] = 0.0f;
      continue;
    }
    cx[k] = float(c.sx / c.pixels);
    cy[k] = float(c.sy / c.pixels);
    cz[k] = float(c.sz / c.pixels);
    const float need = cfg.min_person_area_m2 * focal2 / (cz[k] * cz[k]);
    strict[k] = passes_person_test(f, c, true, true);
    const int32_t low = strict[k] ? 0 : low_person(f, k);
    strict[k] = strict[k] || low > 0;
    outline[k] = low == 2;
    relaxed[k] = c.x_max - c.x_min <= cfg.max_person_width_m && float(c.pixels) >= cfg.tracked_area_fraction * need;
  }
  // Greedy nearest-centroid association: repeatedly the closest (track, component) pair.
  bool track_matched[kMaxUsers] = {};
  float predicted[kMaxUsers][3], reach[kMaxUsers];
  for (int32_t t = 0; t < kMaxUsers; ++t) {
    const Track& tr = tracks_[t];
    const float steps = float(tr.lost_frames + 1);
    for (int k = 0; k < 3; ++k) predicted[t][k] = tr.centroid[k] + tr.velocity[k] * steps;
    reach[t] = cfg.association_distance_m + cfg.association_growth_m * float(tr.lost_frames);
  }
  for (int round = 0; round < kMaxUsers; ++round) {
    int32_t best_t = -1, best_k = -1;
    float best_ratio = 1.0f;  // distance / reach: a lost track's wider reach does not win ties
    for (int32_t t = 0; t < kMaxUsers; ++t) {
      if (!tracks_[t].active || track_matched[t]) continue;
      for (int32_t k = 0; k < n; ++k) {
        if (!relaxed[k] || candidates_[k].user) continue;
        const float dx = cx[k] - predicted[t][0], dy = cy[k] - predicted[t][1], dz = cz[k] - predicted[t][2];
        const float ratio = sqrtf(dx * dx + dy * dy + dz * dz) / reach[t];
        if (ratio <= best_ratio) { best_ratio = ratio; best_t = t; best_k = k; }
      }
    }
    if (best_t < 0) break;
    track_matched[best_t] = true;
    candidates_[best_k].user = best_t + 1;
  }
  // New users: unmatched components passing the full person test, largest first, lowest free id.
  for (int round = 0; round < kMaxCandidates; ++round) {
    int32_t best_k = -1;
    for (int32_t k = 0; k < n; ++k)
      if (strict[k] && !candidates_[k].user && (best_k < 0 || candidates_[k].pixels > candidates_[best_k].pixels))
        best_k = k;
    if (best_k < 0) break;
    if (in_front_of_a_user(f, n, best_k, cz, strict)) {  // a limb reaching out, not someone hidden
      strict[best_k] = false;
      continue;
    }
    const int32_t split = split_box(f, best_k, outline[best_k] && cfg.low_outline_box_split != 0);
    if (split == 2) {  // a box with a hand or arm over it (header, box_reject_min_share)
      strict[best_k] = false;
      continue;
    }
    if (split == 1) {  // a box dropped from a person (header, box_split_height_m)
      const Candidate& c = candidates_[best_k];
      cx[best_k] = float(c.sx / c.pixels);
      cy[best_k] = float(c.sy / c.pixels);
      cz[best_k] = float(c.sz / c.pixels);
    }
    const int32_t pair = split_pair(f, n, best_k);
    if (pair >= 0) {  // two people joined by an arm (header, pair_bridge_max_m): the other one waits its round
      ++n;
      for (int32_t side = 0; side < 2; ++side) {
        const int32_t j = side == 0 ? best_k : pair;
        const Candidate& c = candidates_[j];
        cx[j] = float(c.sx / c.pixels);
        cy[j] = float(c.sy / c.pixels);
        cz[j] = float(c.sz / c.pixels);
      }
      strict[pair] = true;
      relaxed[pair] = false;
    }
    const int32_t into = absorbing_user(f, n, best_k, cx, cy, cz);
    if (into >= 0) {  // a piece of that user's body behind a depth jump (header, absorb_radius_m, head_radius_m)
      strict[best_k] = false;
      Candidate& dst = candidates_[into];
      Candidate& src = candidates_[best_k];
      add_stats(dst, src, floor_->valid != 0);
      cx[into] = float(dst.sx / dst.pixels);
      cy[into] = float(dst.sy / dst.pixels);
      cz[into] = float(dst.sz / dst.pixels);
      for (int32_t j = 0; j < n; ++j)
        if (candidates_[j].owner == best_k) candidates_[j].owner = into;  // best_k's own pieces too
      src.pixels = 0;
      continue;
    }
    int32_t slot = -1;
    for (int32_t t = 0; t < cfg.max_users && slot < 0; ++t)
      if (!tracks_[t].active) slot = t;
    if (slot < 0) {
      r->flags |= kSegFlagUsersTruncated;
      break;
    }
    tracks_[slot] = Track{1, 0, 0, {cx[best_k], cy[best_k], cz[best_k]}, {0, 0, 0}};
    track_matched[slot] = true;
    candidates_[best_k].user = slot + 1;
  }
  // Tracks and the visible users, by id.
  for (int32_t t = 0; t < kMaxUsers; ++t) {
    Track& tr = tracks_[t];
    if (!tr.active) continue;
    if (!track_matched[t]) {
      tr.frames_tracked = 0;
      if (++tr.lost_frames > cfg.track_keep_frames) tr.active = 0;
      continue;
    }
    int32_t k = 0;
    while (candidates_[k].user != t + 1) ++k;
    const Candidate& c = candidates_[k];
    // Velocity: smoothed displacement per frame (a reappearing user spreads it over the gap).
    const float now[3] = {cx[k], cy[k], cz[k]};
    const float gap = float(tr.lost_frames + 1);
    for (int a = 0; a < 3; ++a) {
      tr.velocity[a] = tr.frames_tracked > 0 || tr.lost_frames > 0
                           ? 0.5f * tr.velocity[a] + 0.5f * (now[a] - tr.centroid[a]) / gap
                           : 0.0f;
      tr.centroid[a] = now[a];
    }
    tr.lost_frames = 0;
    if (tr.frames_tracked < 0x7fffffff) ++tr.frames_tracked;
    UserInfo& u = r->users[r->user_count++];
    u.id = t + 1;
    u.pixel_count = c.pixels;
    u.centroid_m[0] = cx[k]; u.centroid_m[1] = cy[k]; u.centroid_m[2] = cz[k];
    u.u_min = c.u_min; u.v_min = c.v_min; u.u_max = c.u_max; u.v_max = c.v_max;
    u.top_height_m = c.top;
    u.frames_tracked = tr.frames_tracked;
    r->user_pixels += c.pixels;
  }
  // The label image.
  const int32_t w = f.width;
  for (int32_t v = 0; v < f.height; ++v) {
    uint8_t* out = r->labels + size_t(v) * f.stride_px;
    const int32_t* parent = parent_ + size_t(v) * w;
    for (int32_t u = 0; u < w; ++u) {
      const int32_t root = parent[u];
      const int32_t k = root >= 0 ? aux_[root] : -1;
      out[u] = k >= 0 ? uint8_t(candidates_[candidates_[k].owner].user) : 0;
    }
  }
}

void Segmenter::update_background(const DepthFrame& f, const uint8_t* labels, const SegmentationResult* r) {
  const SegmenterConfig& cfg = *config_;
  const int32_t w = f.width;
  const bool learning = state_->frames < cfg.background_learn_frames;
  const int32_t reveal = learning ? 1 : cfg.background_reveal_frames;
  // Pixels near a user that are not labelled with it are often the user's own loose pieces (a
  // hand cut off by a depth jump, feet within the floor margin) or another user's. Learned, they
  // would later remove that body part wherever it returns, so nothing inside a user's box (grown
  // by a margin) is learned; that background is learned once the user has moved on.
  int32_t box_u0[kMaxUsers], box_u1[kMaxUsers], box_v0[kMaxUsers], box_v1[kMaxUsers];
  const int32_t boxes = r->user_count;
  for (int32_t i = 0; i < boxes; ++i) {
    const UserInfo& user = r->users[i];
    const int32_t mu = 4 + (user.u_max - user.u_min) / 8, mv = 4 + (user.v_max - user.v_min) / 16;
    box_u0[i] = user.u_min - mu;
    box_u1[i] = user.u_max + mu;
    box_v0[i] = user.v_min - mv;
    box_v1[i] = user.v_max + mv;
  }
  for (int32_t v = 0; v < f.height; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const uint8_t* lab = labels + size_t(v) * f.stride_px;
    BackgroundCell* bg = background_ + size_t(v) * w;
    int32_t row_u0[kMaxUsers], row_u1[kMaxUsers], row_boxes = 0;
    for (int32_t i = 0; i < boxes; ++i)
      if (v >= box_v0[i] && v <= box_v1[i]) {
        row_u0[row_boxes] = box_u0[i];
        row_u1[row_boxes++] = box_u1[i];
      }
    for (int32_t u = 0; u < w; ++u) {
      const uint16_t z = row[u];
      if (z == 0 || lab[u] != 0) continue;  // users never enter the model
      bool near_user = false;
      for (int32_t i = 0; i < row_boxes; ++i) near_user = near_user || (u >= row_u0[i] && u <= row_u1[i]);
      if (near_user) continue;
      BackgroundCell& c = bg[u];
      if (c.depth_mm == 0) {
        c = BackgroundCell{z, 0, 0, 1};
        continue;
      }
      const int32_t diff = int32_t(z) - int32_t(c.depth_mm);
      const float tol = tolerance_mm(cfg.background_tolerance_mm, cfg.background_tolerance_per_m2_mm, float(z));
      if (float(diff < 0 ? -diff : diff) <= tol) {
        if (c.learned < cfg.background_learn_frames) {
          c.depth_mm = uint16_t(int32_t(c.depth_mm) + diff / int32_t(c.learned + 1));
          ++c.learned;
        } else {
          c.depth_mm = uint16_t(int32_t(c.depth_mm) + diff / (1 << cfg.background_update_shift));
        }
        c.far_frames = c.near_frames = 0;
      } else if (diff > 0) {  // farther than the model: something that stood there moved away
        c.near_frames = 0;
        if (c.far_frames < 65535) ++c.far_frames;
        if (c.far_frames >= reveal) c = BackgroundCell{z, 0, 0, 1};
      } else {                // nearer and not a user: an object placed (absorbed only if asked)
        c.far_frames = 0;
        if (c.near_frames < 65535) ++c.near_frames;
        if (cfg.background_absorb_frames > 0 && c.near_frames >= cfg.background_absorb_frames)
          c = BackgroundCell{z, 0, 0, 1};
      }
    }
  }
}

}  // namespace dp
