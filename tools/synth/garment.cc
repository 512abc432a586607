#include "tools/synth/garment.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "tools/common/error.h"

namespace dp::synth {
using dp::tools::fail;

namespace {

constexpr double kMetresPerUnit = 0.1;  // the base mesh and mhclo offsets are in decimetres
// A garment far larger than any MakeHuman asset is malformed, not big: bounds the work a file
// can ask for (the largest CC0 outfit has 8426 vertices and ~17k triangles).
constexpr size_t kMaxGarmentVertices = 1u << 20;
constexpr size_t kMaxGarmentTriangles = 1u << 21;

// Whitespace-separated words of one line (CR and tabs count as space).
std::vector<std::string> words_of(const std::string& line) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// Calls fn(line_number, line) for every line of text (LF or CRLF).
template <typename Fn>
void for_each_line(const std::string& text, Fn fn) {
  size_t start = 0;
  int line_no = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    fn(++line_no, text.substr(start, end - start));
    start = end + 1;
  }
}

class LineContext {
 public:
  LineContext(const std::string& path, int line) : path_(path), line_(line) {}
  [[noreturn]] void error(const std::string& what) const {
    fail(path_ + ":" + std::to_string(line_) + ": " + what);
  }
  uint32_t index(const std::string& word, size_t limit, const std::string& field) const {
    if (word.empty() || word[0] < '0' || word[0] > '9') error(field + ": expected a vertex index, got '" + word + "'");
    errno = 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(word.c_str(), &end, 10);
    if (*end != '\0' || errno == ERANGE) error(field + ": expected a vertex index, got '" + word + "'");
    if (v >= limit)
      error(field + ": vertex " + word + " outside the base mesh (0.." + std::to_string(limit - 1) + ")");
    return uint32_t(v);
  }
  double number(const std::string& word, const std::string& field) const {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(word.c_str(), &end);
    if (word.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
      error(field + ": expected a finite number, got '" + word + "'");
    return v;
  }

 private:
  const std::string& path_;
  int line_;
};

bool is_metadata_keyword(const std::string& w) {
  static const char* const kKeywords[] = {"uuid",     "tag",     "name",     "obj_file",
                                          "material", "z_depth", "max_pole", "vertexboneweights_file",
                                          "basemesh", "author",  "license",  "description"};
  for (const char* k : kKeywords)
    if (w == k) return true;
  return false;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail("cannot open " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  if (f.bad()) fail("cannot read " + path);
  return ss.str();
}

}  // namespace

Garment parse_mhclo(const std::string& text, const std::string& path, size_t base_vertex_count) {
  Garment g;
  enum class Section { kHeader, kVerts, kDelete } section = Section::kHeader;
  bool saw_basemesh = false;
  std::vector<uint8_t> hidden(base_vertex_count, 0);  // delete_verts as a mask: repeated ranges cost nothing
  for_each_line(text, [&](int line_no, const std::string& line) {
    const std::vector<std::string> w = words_of(line);
    if (w.empty() || w[0][0] == '#') return;
    const LineContext at(path, line_no);
    const char c = w[0][0];
    const bool numeric = (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.';
    if (!numeric) {
      const std::string& key = w[0];
      if (key == "verts") {
        if (w.size() != 2 || w[1] != "0") at.error("verts: expected 'verts 0' (bindings to the base mesh)");
        if (!g.bindings.empty()) at.error("verts: a second binding section");
        section = Section::kVerts;
      } else if (key == "delete_verts") {
        if (w.size() != 1) at.error("delete_verts: the indices start on the next line");
        section = Section::kDelete;
      } else if (key == "x_scale" || key == "y_scale" || key == "z_scale") {
        if (w.size() != 4) at.error(key + ": expected 'vertex vertex denominator', got " + std::to_string(w.size() - 1) + " fields");
        GarmentScale& s = g.scales[size_t(key[0] - 'x')];
        s.present = true;
        s.a = at.index(w[1], base_vertex_count, key + " first vertex");
        s.b = at.index(w[2], base_vertex_count, key + " second vertex");
        s.denominator = at.number(w[3], key + " denominator");
        if (!(s.denominator > 0)) at.error(key + " denominator: must be > 0, got '" + w[3] + "'");
      } else if (is_metadata_keyword(key)) {
        if (w.size() < 2) at.error(key + ": missing value");
        if (key == "basemesh") {
          if (w[1] != "hm08") at.error("basemesh: only hm08 is supported, got '" + w[1] + "'");
          saw_basemesh = true;
        } else if (key == "name") {
          g.name = w[1];
        } else if (key == "obj_file") {
          if (w.size() != 2) at.error("obj_file: expected one file name");
          g.obj_file = w[1];
        }
      } else {
        at.error("unknown keyword '" + key + "'");
      }
      return;
    }
    if (section == Section::kVerts) {
      GarmentBinding b;
      if (w.size() == 1) {
        const uint32_t v = at.index(w[0], base_vertex_count, "binding vertex");
        b.vertices = {v, v, v};
        b.weights = {1, 0, 0};
      } else if (w.size() == 9) {
        for (int i = 0; i < 3; ++i)
          b.vertices[size_t(i)] = at.index(w[size_t(i)], base_vertex_count, "binding vertex " + std::to_string(i + 1));
        for (int i = 0; i < 3; ++i)
          b.weights[size_t(i)] = float(at.number(w[size_t(3 + i)], "binding weight " + std::to_string(i + 1)));
        for (int i = 0; i < 3; ++i)
          b.offset[size_t(i)] = float(at.number(w[size_t(6 + i)], std::string("binding offset ") + "xyz"[i]));
      } else {
        at.error("binding: expected 9 fields (3 vertices, 3 weights, 3 offsets) or 1, got " + std::to_string(w.size()));
      }
      if (g.bindings.size() >= kMaxGarmentVertices) at.error("binding: more than " + std::to_string(kMaxGarmentVertices) + " vertices");
      g.bindings.push_back(b);
    } else if (section == Section::kDelete) {
      for (size_t i = 0; i < w.size(); ++i) {
        const uint32_t lo = at.index(w[i], base_vertex_count, "delete_verts");
        uint32_t hi = lo;
        if (i + 1 < w.size() && w[i + 1] == "-") {
          if (i + 2 >= w.size()) at.error("delete_verts: range '" + w[i] + " -' has no end on its line");
          hi = at.index(w[i + 2], base_vertex_count, "delete_verts range end");
          if (hi < lo) at.error("delete_verts: range " + w[i] + " - " + w[i + 2] + " runs backwards");
          i += 2;
        }
        std::fill(hidden.begin() + lo, hidden.begin() + hi + 1, uint8_t(1));
      }
    } else {
      at.error("numbers before 'verts 0' or 'delete_verts'");
    }
  });
  if (!saw_basemesh) fail(path + ": no 'basemesh hm08' line");
  if (g.obj_file.empty()) fail(path + ": no 'obj_file' line");
  if (g.bindings.empty()) fail(path + ": no vertex bindings (a 'verts 0' section)");
  for (size_t v = 0; v < hidden.size(); ++v)
    if (hidden[v]) g.delete_vertices.push_back(uint32_t(v));
  if (g.name.empty()) {
    const size_t slash = path.find_last_of('/');
    g.name = path.substr(slash == std::string::npos ? 0 : slash + 1);
    const size_t dot = g.name.rfind('.');
    if (dot != std::string::npos && dot > 0) g.name.resize(dot);
  }
  return g;
}

void parse_garment_obj(const std::string& text, const std::string& path, Garment& g) {
  g.triangles.clear();
  g.obj_vertex_count = 0;
  // Faces may precede some `v` lines in principle; corners are checked once the count is known.
  std::vector<std::pair<int, std::vector<long long>>> faces;
  for_each_line(text, [&](int line_no, const std::string& line) {
    const std::vector<std::string> w = words_of(line);
    if (w.empty() || w[0][0] == '#') return;
    const LineContext at(path, line_no);
    if (w[0] == "v") {
      if (w.size() != 4 && w.size() != 5) at.error("v: expected x y z, got " + std::to_string(w.size() - 1) + " fields");
      for (size_t i = 1; i < 4; ++i) at.number(w[i], std::string("v ") + "xyz"[i - 1]);
      if (++g.obj_vertex_count > kMaxGarmentVertices) at.error("v: more than " + std::to_string(kMaxGarmentVertices) + " vertices");
    } else if (w[0] == "f") {
      if (w.size() < 4) at.error("f: a face needs at least 3 corners, got " + std::to_string(w.size() - 1));
      std::vector<long long> corners;
      for (size_t i = 1; i < w.size(); ++i) {
        const std::string v = w[i].substr(0, w[i].find('/'));
        errno = 0;
        char* end = nullptr;
        const long long n = std::strtoll(v.c_str(), &end, 10);
        if (v.empty() || *end != '\0' || errno == ERANGE || n == 0)
          at.error("f corner " + std::to_string(i) + ": expected a vertex number, got '" + w[i] + "'");
        corners.push_back(n < 0 ? n + (long long)g.obj_vertex_count : n - 1);  // 0-based
        if (n < 0 && corners.back() < 0)
          at.error("f corner " + std::to_string(i) + ": relative vertex " + v + " before the first vertex");
      }
      faces.push_back({line_no, std::move(corners)});
    } else if (w[0] == "vt" || w[0] == "vn" || w[0] == "g" || w[0] == "o" || w[0] == "s" || w[0] == "usemtl" ||
               w[0] == "mtllib") {
      return;
    } else {
      at.error("unknown record '" + w[0] + "'");
    }
  });
  size_t triangle_count = 0;
  for (const auto& [line_no, corners] : faces) {
    triangle_count += corners.size() - 2;
    if (triangle_count > kMaxGarmentTriangles)
      fail(path + ":" + std::to_string(line_no) + ": f: more than " + std::to_string(kMaxGarmentTriangles) + " triangles");
    for (size_t i = 0; i < corners.size(); ++i)
      if (corners[i] < 0 || size_t(corners[i]) >= g.obj_vertex_count)
        fail(path + ":" + std::to_string(line_no) + ": f corner " + std::to_string(i + 1) + ": vertex " +
             std::to_string(corners[i] + 1) + " outside the file's " + std::to_string(g.obj_vertex_count) + " vertices");
  }
  g.triangles.reserve(triangle_count);
  for (const auto& face : faces) {
    const std::vector<long long>& c = face.second;
    for (size_t i = 1; i + 1 < c.size(); ++i) g.triangles.push_back({uint32_t(c[0]), uint32_t(c[i]), uint32_t(c[i + 1])});
  }
  if (g.triangles.empty()) fail(path + ": no faces");
  if (g.obj_vertex_count != g.bindings.size())
    fail(path + ": " + std::to_string(g.obj_vertex_count) + " vertices, but its mhclo binds " +
         std::to_string(g.bindings.size()));
}

Garment load_garment(const std::string& mhclo_path, size_t base_vertex_count) {
  Garment g = parse_mhclo(read_text(mhclo_path), mhclo_path, base_vertex_count);
  if (g.obj_file.find("..") != std::string::npos || g.obj_file[0] == '/')
    fail(mhclo_path + ": obj_file '" + g.obj_file + "' must name a file beside the mhclo");
  const size_t slash = mhclo_path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "" : mhclo_path.substr(0, slash + 1);
  const std::string obj_path = dir + g.obj_file;
  parse_garment_obj(read_text(obj_path), obj_path, g);
  return g;
}

Vec3 garment_offset_scale(const Garment& g, const std::vector<Vec3f>& body) {
  double s[3];
  for (int axis = 0; axis < 3; ++axis) {
    const GarmentScale& sc = g.scales[size_t(axis)];
    if (!sc.present) {
      s[axis] = kMetresPerUnit;
      continue;
    }
    const Vec3f& a = body[sc.a];
    const Vec3f& b = body[sc.b];
    const float d = axis == 0 ? a.x - b.x : (axis == 1 ? a.y - b.y : a.z - b.z);
    s[axis] = std::fabs(double(d)) / sc.denominator;  // metres per unit: |d| (m) * 10 / D * 0.1
  }
  return {s[0], s[1], s[2]};
}

void fit_garment(const Garment& g, const std::vector<Vec3f>& body, std::vector<Vec3f>& out) {
  const Vec3 s = garment_offset_scale(g, body);
  const float sx = float(s.x), sy = float(s.y), sz = float(s.z);
  out.resize(g.bindings.size());
  for (size_t i = 0; i < g.bindings.size(); ++i) {
    const GarmentBinding& b = g.bindings[i];
    const Vec3f& p0 = body[b.vertices[0]];
    const Vec3f& p1 = body[b.vertices[1]];
    const Vec3f& p2 = body[b.vertices[2]];
    const float w0 = b.weights[0], w1 = b.weights[1], w2 = b.weights[2];
    out[i] = {w0 * p0.x + w1 * p1.x + w2 * p2.x + b.offset[0] * sx, w0 * p0.y + w1 * p1.y + w2 * p2.y + b.offset[1] * sy,
              w0 * p0.z + w1 * p1.z + w2 * p2.z + b.offset[2] * sz};
  }
}

}  // namespace dp::synth
