#include "runtime/segmentation/background.h"

namespace dp::seg {

int32_t classify_pixels(const SegmenterConfig& cfg, const DepthFrame& f, const FloorPlane& floor, const BackgroundCell* background,
                        int32_t frames_seen, int32_t* pixel_parent, int32_t* pixel_aux) {
  const int32_t w = f.width, h = f.height;
  const bool use_floor = floor.valid != 0;
  const bool use_background = cfg.background_enabled && frames_seen > 0;
  // Signed height above the floor of pixel (u, v) at depth z metres: z·(a·u + b_v) + d.
  const float a = use_floor ? floor.nx / f.intrinsics.fx : 0.0f;
  const float a0 = use_floor ? -floor.nx * f.intrinsics.cx / f.intrinsics.fx + floor.nz : 0.0f;
  int32_t count = 0;
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const BackgroundCell* bg = background + size_t(v) * w;
    int32_t* parent = pixel_parent + size_t(v) * w;
    int32_t* aux = pixel_aux + size_t(v) * w;
    const float bv = use_floor ? a0 - floor.ny * (float(v) - f.intrinsics.cy) / f.intrinsics.fy : 0.0f;
    // A pixel the model has never seen without a user on it (someone stood there from the start)
    // is judged by chains along the row from known model pixels, leftwards and rightwards: an
    // unseen reading not nearer than the chain's depth (by more than the tolerance) is background
    // and carries the chain on at its own depth; a nearer one is foreground and leaves the chain
    // unchanged; more than kChainGap readings missing in a row break it. Where a person has
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
        const float height_mm = (float(z) * (a * float(u) + bv) + floor.d * 1000.0f);
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

void update_background(const SegmenterConfig& cfg, const DepthFrame& f, const uint8_t* labels, const SegmentationResult* r,
                       int32_t frames_seen, BackgroundCell* background) {
  const int32_t w = f.width;
  const bool learning = frames_seen < cfg.background_learn_frames;
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
    BackgroundCell* bg = background + size_t(v) * w;
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

}  // namespace dp::seg
