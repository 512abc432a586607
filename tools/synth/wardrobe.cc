#include "tools/synth/wardrobe.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "tools/common/error.h"

namespace dp::synth {
using dp::tools::fail;
namespace fs = std::filesystem;

namespace {

// Nearest body vertex by a uniform grid over the rest body (cells of kCell metres): rings of cells
// around the query until the nearest found is closer than any unvisited cell can be.
class NearestBodyVertex {
 public:
  explicit NearestBodyVertex(const std::vector<Vec3f>& v) : v_(v) {
    lo_ = hi_ = v[0];
    for (int i = 0; i < kBodyVertexCount; ++i) {
      lo_ = {std::min(lo_.x, v[i].x), std::min(lo_.y, v[i].y), std::min(lo_.z, v[i].z)};
      hi_ = {std::max(hi_.x, v[i].x), std::max(hi_.y, v[i].y), std::max(hi_.z, v[i].z)};
    }
    for (int a = 0; a < 3; ++a) n_[a] = 1 + int((coord(hi_, a) - coord(lo_, a)) / kCell);
    cells_.resize(size_t(n_[0]) * n_[1] * n_[2]);
    for (int i = 0; i < kBodyVertexCount; ++i) {
      int c[3];
      cell_of(v[i], c);
      cells_[index(c)].push_back(uint32_t(i));
    }
  }
  uint32_t operator()(const Vec3f& q) const {
    int c[3];
    cell_of(q, c);
    // Cells are clamped, so a query outside the grid may need more rings; the bound below adds
    // the query's distance outside the grid box.
    double outside = 0;
    for (int a = 0; a < 3; ++a)
      outside = std::max({outside, double(coord(lo_, a) - coord(q, a)), double(coord(q, a) - coord(hi_, a))});
    double best = std::numeric_limits<double>::infinity();
    uint32_t best_i = 0;
    const int max_ring = std::max({n_[0], n_[1], n_[2]});
    for (int r = 0; r <= max_ring; ++r) {
      for (int x = c[0] - r; x <= c[0] + r; ++x)
        for (int y = c[1] - r; y <= c[1] + r; ++y)
          for (int z = c[2] - r; z <= c[2] + r; ++z) {
            if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != r) continue;
            if (x < 0 || y < 0 || z < 0 || x >= n_[0] || y >= n_[1] || z >= n_[2]) continue;
            const int cc[3] = {x, y, z};
            for (uint32_t i : cells_[index(cc)]) {
              const double dx = v_[i].x - q.x, dy = v_[i].y - q.y, dz = v_[i].z - q.z;
              const double d = dx * dx + dy * dy + dz * dz;
              if (d < best || (d == best && i < best_i)) {
                best = d;
                best_i = i;
              }
            }
          }
      // Every vertex in ring r+1 or beyond is at least r*kCell - outside away (Chebyshev).
      const double reach = r * kCell - outside;
      if (reach > 0 && best <= reach * reach) break;
    }
    return best_i;
  }

 private:
  static constexpr double kCell = 0.03;  // metres; ~10 body vertices per occupied cell
  static float coord(const Vec3f& p, int a) { return a == 0 ? p.x : (a == 1 ? p.y : p.z); }
  void cell_of(const Vec3f& p, int c[3]) const {
    for (int a = 0; a < 3; ++a) c[a] = std::clamp(int((coord(p, a) - coord(lo_, a)) / kCell), 0, n_[a] - 1);
  }
  size_t index(const int c[3]) const { return (size_t(c[0]) * n_[1] + c[1]) * n_[2] + c[2]; }

  const std::vector<Vec3f>& v_;
  Vec3f lo_, hi_;
  int n_[3] = {1, 1, 1};
  std::vector<std::vector<uint32_t>> cells_;
};

WornGarment prepare(Garment g, const std::string& path, const HumanAssets& assets, const std::vector<uint8_t>& body_labels,
                    const NearestBodyVertex& nearest) {
  WornGarment w;
  w.path = path;
  std::vector<Vec3f> rest;
  fit_garment(g, assets.base_vertices, rest);
  w.labels.resize(rest.size());
  for (size_t i = 0; i < rest.size(); ++i) w.labels[i] = body_labels[nearest(rest[i])];
  for (const GarmentBinding& b : g.bindings)
    for (uint32_t v : b.vertices) w.bound_vertices.push_back(v);
  std::sort(w.bound_vertices.begin(), w.bound_vertices.end());
  w.bound_vertices.erase(std::unique(w.bound_vertices.begin(), w.bound_vertices.end()), w.bound_vertices.end());
  for (uint32_t v : w.bound_vertices)
    if (assets.skin_offsets[v] == assets.skin_offsets[v + 1])
      fail(path + ": binds to base vertex " + std::to_string(v) + ", which has no skin weights");
  w.slots.reserve(g.bindings.size());
  for (const GarmentBinding& b : g.bindings) {
    std::array<uint32_t, 3> s;
    for (int i = 0; i < 3; ++i)
      s[size_t(i)] = uint32_t(std::lower_bound(w.bound_vertices.begin(), w.bound_vertices.end(), b.vertices[size_t(i)]) -
                              w.bound_vertices.begin());
    w.slots.push_back(s);
  }
  w.garment = std::move(g);
  return w;
}

}  // namespace

bool Wardrobe::empty() const {
  for (const auto& list : items)
    if (!list.empty()) return false;
  return true;
}

WornGarment prepare_garment(Garment g, const std::string& path, const HumanAssets& assets,
                            const std::vector<uint8_t>& body_labels) {
  const NearestBodyVertex nearest(assets.base_vertices);
  return prepare(std::move(g), path, assets, body_labels, nearest);
}

Wardrobe load_wardrobe(const std::string& assets_dir, const HumanAssets& assets, const std::vector<uint8_t>& body_labels) {
  const std::string root = assets_dir + "/makehuman";
  std::vector<std::pair<std::string, GarmentKind>> files;
  for (const char* top : {"clothes", "hair"}) {
    const std::string dir = root + "/" + top;
    if (!fs::is_directory(dir)) fail("garment folder " + dir + " does not exist (is --assets pointing at ../shared/assets?)");
    for (const auto& item : fs::directory_iterator(dir)) {
      if (!item.is_directory()) continue;
      const std::string folder = item.path().filename().string();
      GarmentKind kind = GarmentKind::kOutfit;
      if (std::string(top) == "hair") kind = GarmentKind::kHair;
      else if (folder.rfind("shoes", 0) == 0) kind = GarmentKind::kShoes;
      else if (folder.rfind("fedora", 0) == 0) kind = GarmentKind::kHat;
      for (const auto& f : fs::directory_iterator(item.path()))
        if (f.is_regular_file() && f.path().extension() == ".mhclo") files.push_back({f.path().string(), kind});
    }
  }
  std::sort(files.begin(), files.end());
  const NearestBodyVertex nearest(assets.base_vertices);
  Wardrobe w;
  for (const auto& [path, kind] : files)
    w.items[size_t(kind)].push_back(prepare(load_garment(path, assets.base_vertices.size()), path, assets, body_labels, nearest));
  static const char* const kKindNames[] = {"outfit", "shoes", "hat", "hairstyle"};
  for (int k = 0; k < kGarmentKindCount; ++k)
    if (w.items[size_t(k)].empty()) fail(root + ": no " + kKindNames[k] + " .mhclo found under clothes/ or hair/");
  return w;
}

void pose_garment(const WornGarment& w, const HumanAssets& assets, const std::vector<Vec3f>& shaped,
                  const std::vector<SkinTransform>& bones, std::vector<Vec3f>& out) {
  thread_local std::vector<SkinTransform> transform;
  thread_local std::vector<Vec3f> posed;
  transform.resize(w.bound_vertices.size());
  posed.resize(w.bound_vertices.size());
  for (size_t i = 0; i < w.bound_vertices.size(); ++i) {
    const uint32_t v = w.bound_vertices[i];
    transform[i] = vertex_skin_transform(assets, bones, v);
    posed[i] = transform[i].apply(shaped[v]);
  }
  const Garment& g = w.garment;
  const Vec3 s = garment_offset_scale(g, shaped);
  out.resize(g.bindings.size());
  for (size_t i = 0; i < g.bindings.size(); ++i) {
    const GarmentBinding& b = g.bindings[i];
    const std::array<uint32_t, 3>& slot = w.slots[i];
    SkinTransform blend;
    Vec3f p{0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      const float wk = b.weights[size_t(k)];
      const Vec3f& q = posed[slot[size_t(k)]];
      p = {p.x + wk * q.x, p.y + wk * q.y, p.z + wk * q.z};
      const SkinTransform& t = transform[slot[size_t(k)]];
      for (int e = 0; e < 9; ++e) blend.m[e] += wk * t.m[e];
    }
    const Vec3f d = blend.rotate({b.offset[0] * float(s.x), b.offset[1] * float(s.y), b.offset[2] * float(s.z)});
    out[i] = {p.x + d.x, p.y + d.y, p.z + d.z};
  }
}

void dress_body(const Wardrobe& wardrobe, const Outfit& outfit, const HumanAssets& assets,
                const std::vector<uint8_t>& body_labels, const std::vector<Vec3f>& shaped,
                const std::vector<SkinTransform>& bones, std::vector<Vec3f>& verts, std::vector<uint8_t>& labels,
                std::vector<std::array<uint32_t, 3>>& triangles) {
  const std::pair<GarmentKind, int> worn[] = {{GarmentKind::kOutfit, outfit.outfit},
                                              {GarmentKind::kShoes, outfit.shoes},
                                              {GarmentKind::kHat, outfit.hat},
                                              {GarmentKind::kHair, outfit.hair}};
  thread_local std::vector<uint8_t> hidden;
  hidden.assign(kBodyVertexCount, 0);
  labels.assign(body_labels.begin(), body_labels.end());
  triangles.clear();
  thread_local std::vector<Vec3f> garment_verts;
  std::vector<std::array<uint32_t, 3>> garment_triangles;
  for (const auto& [kind, index] : worn) {
    if (index < 0) continue;
    const std::vector<WornGarment>& list = wardrobe.of(kind);
    if (size_t(index) >= list.size()) fail("outfit index out of range");
    const WornGarment& g = list[size_t(index)];
    for (uint32_t v : g.garment.delete_vertices)
      if (v < uint32_t(kBodyVertexCount)) hidden[v] = 1;
    pose_garment(g, assets, shaped, bones, garment_verts);
    const uint32_t base = uint32_t(verts.size());
    verts.insert(verts.end(), garment_verts.begin(), garment_verts.end());
    labels.insert(labels.end(), g.labels.begin(), g.labels.end());
    for (const auto& t : g.garment.triangles) garment_triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  for (const auto& t : assets.body_triangles)
    if (!hidden[t[0]] && !hidden[t[1]] && !hidden[t[2]]) triangles.push_back(t);
  triangles.insert(triangles.end(), garment_triangles.begin(), garment_triangles.end());
}

}  // namespace dp::synth
