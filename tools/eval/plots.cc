#include "tools/eval/plots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "tools/common/error.h"
#include "tools/common/png_io.h"
#include "tools/eval/raster.h"

namespace dp::tools {
namespace {

const Rgb kBlack{0, 0, 0}, kGrey{200, 200, 200}, kDark{90, 90, 90}, kRed{220, 30, 30}, kWhite{255, 255, 255};

std::string num(double v, int decimals) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}
std::string ap_text(const std::optional<double>& v) { return v ? num(*v, 3) : "N/A"; }

// A plot coordinate as a pixel: far-off or non-finite values (a truth joint or proposal far outside
// the image) land well off the canvas instead of overflowing the int conversion.
int to_pixel(double v) {
  constexpr double kOff = 1e6;
  return v > -kOff && v < kOff ? int(v) : -int(kOff);
}

// A rectangular plotting area mapping data (x, y) to pixels; y grows upwards.
struct Axes {
  Canvas& c;
  int left, top, right, bottom;
  double xmin, xmax, ymin, ymax;
  double px(double x) const { return left + (x - xmin) / (xmax - xmin) * (right - left); }
  double py(double y) const { return bottom - (y - ymin) / (ymax - ymin) * (bottom - top); }

  void draw(const std::string& xlabel, const std::string& ylabel, int xticks, int yticks, int decimals) {
    for (int i = 0; i <= xticks; ++i) {
      const double x = xmin + (xmax - xmin) * i / xticks;
      c.line(px(x), top, px(x), bottom, kGrey);
      const std::string t = num(x, decimals);
      c.text(to_pixel(px(x)) - Canvas::text_width(t) / 2, bottom + 4, t, kDark);
    }
    for (int i = 0; i <= yticks; ++i) {
      const double y = ymin + (ymax - ymin) * i / yticks;
      c.line(left, py(y), right, py(y), kGrey);
      const std::string t = num(y, decimals);
      c.text(left - 4 - Canvas::text_width(t), to_pixel(py(y)) - 3, t, kDark);
    }
    c.rect(left, top, right, bottom, kBlack);
    c.text((left + right) / 2 - Canvas::text_width(xlabel) / 2, bottom + 14, xlabel, kBlack);
    c.text(left - 4 - Canvas::text_width(ylabel), top - 12, ylabel, kBlack);
  }
  void polyline(const std::vector<double>& xs, const std::vector<double>& ys, Rgb col, int thickness) {
    for (size_t i = 1; i < xs.size(); ++i) c.line(px(xs[i - 1]), py(ys[i - 1]), px(xs[i]), py(ys[i]), col, thickness);
  }
};

void save(const Canvas& c, const std::string& path, std::vector<std::string>& written) {
  write_png_rgb(path, c.image());
  written.push_back(path);
}

// Recall–precision, one small panel per joint. The curve starts at (0, first precision).
void plot_pr(const EvalReport& r, const std::string& path, std::vector<std::string>& written) {
  const int n = int(r.joint_names.size());
  const int cols = std::min(4, std::max(1, n)), rows = (n + cols - 1) / cols;
  const int pw = 230, ph = 200;
  Canvas c(cols * pw, rows * ph + 30);
  c.text(10, 8, "RECALL (X) - PRECISION (Y) PER JOINT, " + r.method + ", D_TP " + num(r.d_tp, 2) + " " + r.d_tp_unit +
                    ", MAP " + ap_text(r.mean_ap), kBlack, 1);
  for (int k = 0; k < n; ++k) {
    const int ox = (k % cols) * pw, oy = 30 + (k / cols) * ph;
    Axes a{c, ox + 50, oy + 22, ox + pw - 15, oy + ph - 34, 0, 1, 0, 1.02};
    a.draw("RECALL", "", 2, 2, 1);
    c.text(ox + 50, oy + 6, r.joint_names[size_t(k)] + " AP " + ap_text(r.ap[size_t(k)]), kBlack);
    const PrCurve& pc = r.curves[size_t(k)];
    if (pc.recall.empty()) continue;
    std::vector<double> xs{0.0}, ys{pc.precision[0]};
    for (size_t i = 0; i < pc.recall.size(); ++i) {
      xs.push_back(pc.recall[i]);
      ys.push_back(pc.precision[i]);
    }
    a.polyline(xs, ys, palette_colour(k), 2);
  }
  save(c, path, written);
}

void plot_ap_vs_dtp(const EvalReport& r, const std::string& path, std::vector<std::string>& written) {
  const int n = int(r.joint_names.size());
  Canvas c(760, 460);
  c.text(10, 8, "AVERAGE PRECISION VS D_TP (" + r.method + (r.silhouette ? ", SILHOUETTE" : "") + ")", kBlack, 1);
  const double xmax = r.dtp_grid.empty() ? 1.0 : r.dtp_grid.back();
  Axes a{c, 60, 40, 560, 410, 0, xmax, 0, 1.0};
  a.draw("D_TP (" + r.d_tp_unit + ")", "AP", 5, 5, r.silhouette ? 0 : 2);
  for (int k = 0; k < n; ++k) {
    std::vector<double> xs, ys;
    for (size_t g = 0; g < r.dtp_grid.size(); ++g)
      if (r.ap_vs_dtp[g][size_t(k)]) {
        xs.push_back(r.dtp_grid[g]);
        ys.push_back(*r.ap_vs_dtp[g][size_t(k)]);
      }
    a.polyline(xs, ys, palette_colour(k), 1);
    c.fill_rect(575, 44 + 12 * k, 585, 50 + 12 * k, palette_colour(k));
    c.text(590, 44 + 12 * k, r.joint_names[size_t(k)], kBlack);
  }
  std::vector<double> xs, ys;
  for (size_t g = 0; g < r.dtp_grid.size(); ++g)
    if (r.map_vs_dtp[g]) {
      xs.push_back(r.dtp_grid[g]);
      ys.push_back(*r.map_vs_dtp[g]);
    }
  a.polyline(xs, ys, kBlack, 3);
  for (size_t i = 0; i < xs.size(); ++i) c.fill_rect(to_pixel(a.px(xs[i])) - 2, to_pixel(a.py(ys[i])) - 2, to_pixel(a.px(xs[i])) + 2, to_pixel(a.py(ys[i])) + 2, kBlack);
  c.fill_rect(575, 44 + 12 * n + 6, 585, 48 + 12 * n + 6, kBlack);
  c.text(590, 44 + 12 * n + 4, "MAP", kBlack);
  save(c, path, written);
}

void plot_confusion(const EvalReport& r, const std::string& path, std::vector<std::string>& written) {
  const int n = r.confusion.classes();
  const int cell = n <= 12 ? 28 : 16, label_w = 90, top = 60;
  const std::string title = "CONFUSION MATRIX, ROW-NORMALIZED (ROWS: GROUND TRUTH, COLUMNS: MOST LIKELY PART)";
  Canvas c(std::max(label_w + n * cell + 90, Canvas::text_width(title) + 20), top + n * cell + 40);
  c.text(10, 8, title, kBlack);
  c.text(10, 22, "CLASS ACCURACY (MEAN DIAGONAL) " + ap_text(r.class_accuracy), kBlack);
  for (int t = 0; t < n; ++t) {
    c.text(4, top + t * cell + cell / 2 - 3, r.part_names[size_t(t)].substr(0, 14), r.confusion.row_total(t) ? kBlack : kGrey);
    const std::string idx = std::to_string(t);
    c.text(label_w + t * cell + cell / 2 - Canvas::text_width(idx) / 2, top - 12 - (t % 2) * 9, idx, kDark);
    for (int p = 0; p < n; ++p) {
      const double v = r.confusion.row_normalized(t, p);
      const int x0 = label_w + p * cell, y0 = top + t * cell;
      c.fill_rect(x0, y0, x0 + cell - 1, y0 + cell - 1, r.confusion.row_total(t) ? heat_colour(v) : Rgb{240, 240, 240});
      if (p == t) c.rect(x0, y0, x0 + cell - 1, y0 + cell - 1, kRed);
    }
  }
  // Colour bar.
  const int bx = label_w + n * cell + 20;
  for (int y = 0; y < n * cell; ++y) c.line(bx, top + y, bx + 14, top + y, heat_colour(1.0 - double(y) / (n * cell - 1)));
  c.text(bx + 18, top, "1", kBlack);
  c.text(bx + 18, top + n * cell - 7, "0", kBlack);
  save(c, path, written);
}

void plot_overlay(const EvalReport& r, const OverlayFrame& o, const std::string& path, std::vector<std::string>& written) {
  const int scale = o.width < 400 ? 2 : 1;
  const int legend = 110;
  Canvas c(o.width * scale + legend, std::max(o.height * scale, 40 + 12 * int(r.joint_names.size())) + 24, kWhite);
  uint16_t zmin = 65535, zmax = 0;
  for (uint16_t z : o.depth_mm)
    if (z) {
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
    }
  for (int v = 0; v < o.height; ++v)
    for (int u = 0; u < o.width; ++u) {
      const size_t i = size_t(v) * o.width + u;
      Rgb col{0, 0, 0};
      if (o.part[i] >= 0) {
        // Parts dimmed so the proposals (same palette, full brightness) stand out on them.
        const Rgb p = palette_colour(o.part[i]);
        col = Rgb{uint8_t(p.r * 0.6), uint8_t(p.g * 0.6), uint8_t(p.b * 0.6)};
      } else if (o.depth_mm[i]) {
        const double t = zmax > zmin ? double(o.depth_mm[i] - zmin) / double(zmax - zmin) : 0.0;
        const uint8_t g = uint8_t(200 - 150 * t);
        col = Rgb{g, g, g};
      }
      c.fill_rect(u * scale, v * scale, u * scale + scale - 1, v * scale + scale - 1, col);
    }
  float max_conf = 0;
  for (const auto& props : o.proposals)
    for (const ScoredPoint& p : props) max_conf = std::max(max_conf, p.confidence);
  for (size_t k = 0; k < o.proposals.size(); ++k) {
    const Rgb col = palette_colour(int(k));
    const JointSamples::Truth& t = o.truth[k];
    c.cross(to_pixel(double(t.position.x) * scale), to_pixel(double(t.position.y) * scale), 4, t.visible ? kWhite : kGrey);
    for (const ScoredPoint& p : o.proposals[k]) {
      const double rad = 2.0 + 10.0 * (max_conf > 0 ? std::sqrt(p.confidence / max_conf) : 0.0);
      c.circle(p.position.x * scale, p.position.y * scale, rad * scale / 1.5, kBlack, 4);
      c.circle(p.position.x * scale, p.position.y * scale, rad * scale / 1.5, col, 2);
    }
    c.fill_rect(o.width * scale + 8, 30 + 12 * int(k), o.width * scale + 18, 36 + 12 * int(k), col);
    c.text(o.width * scale + 22, 30 + 12 * int(k), r.joint_names[k], kBlack);
  }
  c.text(o.width * scale + 8, 8, "FRAME " + o.id, kBlack);
  c.text(4, o.height * scale + 8,
         std::string(o.part_is_prediction ? "MOST LIKELY PART" : "GROUND-TRUTH PARTS") +
             "; CIRCLES: PROPOSALS (RADIUS ~ CONFIDENCE); X: GROUND TRUTH",
         kBlack);
  save(c, path, written);
}

}  // namespace

std::vector<std::string> write_eval_plots(const EvalReport& r, const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) fail("cannot create plot directory " + dir + ": " + ec.message());
  std::vector<std::string> written;
  if (!r.joint_names.empty()) {
    plot_pr(r, dir + "/recall_precision.png", written);
    plot_ap_vs_dtp(r, dir + "/ap_vs_dtp.png", written);
  }
  if (r.has_confusion) plot_confusion(r, dir + "/confusion.png", written);
  for (const OverlayFrame& o : r.overlays) plot_overlay(r, o, dir + "/overlay_" + o.id + ".png", written);
  return written;
}

}  // namespace dp::tools
