#include "runtime/segmentation/floor.h"

#include <math.h>
#include <string.h>

namespace dp::seg {

namespace {

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

}  // namespace

void fit_floor(const SegmenterConfig& cfg, const DepthFrame& f, int32_t frames_seen, float* samples, uint8_t* inlier,
               FloorPlane* floor, SegmentationResult* r) {
  if (!cfg.floor_enabled) {
    memset(floor, 0, sizeof *floor);
    r->floor = *floor;
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
      float* p = samples + 3 * n++;
      p[0] = (float(u) - f.intrinsics.cx) * zm * inv_fx;
      p[1] = -(float(v) - f.intrinsics.cy) * zm * inv_fy;
      p[2] = zm;
    }
  }
  const float tol = cfg.floor_fit_mm * 0.001f;
  const float min_up = cosf(cfg.floor_max_tilt_deg * 3.14159265f / 180.0f);
  const bool had_plane = floor->valid != 0;
  Plane best{0, 0, 0, 0};
  int32_t best_count = 0, best_score = 0, below = 0;
  if (had_plane) {
    best = Plane{floor->nx, floor->ny, floor->nz, floor->d};
    best_count = count_inliers(best, samples, n, tol, nullptr, &below);
    best_score = floor_score(best_count, below);
  }
  // The cheap tracked search only when last frame's plane still explains most of what it did;
  // otherwise (camera moved, new scene) the full search.
  const bool tracking = had_plane && 2 * best_count >= floor->inliers;
  const int32_t iterations = tracking ? cfg.floor_tracked_iterations : cfg.floor_iterations;
  uint32_t rng = 0x9E3779B9u ^ (uint32_t(frames_seen) * 0x85EBCA77u);
  if (rng == 0) rng = 1;
  auto search = [&](int32_t hypotheses) {
    for (int32_t it = 0; it < hypotheses && n >= 3; ++it) {
      const int32_t a = int32_t(xorshift32(&rng) % uint32_t(n));
      const int32_t b = int32_t(xorshift32(&rng) % uint32_t(n));
      const int32_t c = int32_t(xorshift32(&rng) % uint32_t(n));
      if (a == b || b == c || a == c) continue;
      Plane p;
      if (!plane_from_points(samples + 3 * a, samples + 3 * b, samples + 3 * c, &p)) continue;
      if (!orient_and_check(&p, min_up, cfg.camera_height_min_m, cfg.camera_height_max_m)) continue;
      int32_t count = 0, score = 0;
      if (score_beats(p, samples, n, tol, best_score, &count, &score)) {
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
      if (count_inliers(best, samples, n, tol * band, inlier) < 3) break;
      Plane p;
      if (!refine_plane(samples, inlier, n, &p)) break;
      if (!orient_and_check(&p, min_up, cfg.camera_height_min_m, cfg.camera_height_max_m)) {
        refused = true;
        break;
      }
      best = p;
    }
    best_count = count_inliers(best, samples, n, tol, inlier);
    // A floor spans metres; a torso or a thigh seen from above is a plane too, and with no floor
    // in view (nothing but people) it would win. The inliers' box must have a diagonal of at
    // least floor_min_extent_m.
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (int32_t i = 0; i < n; ++i) {
      if (!inlier[i]) continue;
      for (int k = 0; k < 3; ++k) {
        const float c = samples[3 * i + k];
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
    *floor = FloorPlane{best.nx, best.ny, best.nz, best.d, 1, best_count, n, 0};
    r->flags |= kSegFlagFloorFitted;
  } else if (had_plane && floor->held_frames < cfg.floor_keep_frames) {
    ++floor->held_frames;
    floor->inliers = best_count;
    floor->samples = n;
    r->flags |= kSegFlagFloorHeld;
  } else {
    memset(floor, 0, sizeof *floor);
    floor->samples = n;
    floor->inliers = best_count;
  }
  r->floor = *floor;
}


}  // namespace dp::seg
