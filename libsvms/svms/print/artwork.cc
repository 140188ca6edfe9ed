#include "svms/print/artwork.h"

#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>

#include "svms/base/file_io.h"
#include "svms/codec/svms44.h"
#include "svms/marker/model_io.h"
#include "svms/print/png_encode.h"

namespace svms {
namespace {

constexpr double kMmPerM = 1000.0;
constexpr double kCutMarkLength = 5.0, kCutMarkOffset = 1.5;  // mm

// Everything drawn about one marker sits in a box: cut box (ring + quiet zone) plus room for
// cut marks around it and the label below it.
struct MarkerBox {
  double cut_half_mm;  // half side of the cut square
  double label_mm;     // height of the label line (0 if none)
  double font_mm;
  double width() const { return 2 * (cut_half_mm + kCutMarkOffset + kCutMarkLength); }
  double height() const { return width() + label_mm; }
};

MarkerBox BoxFor(const MarkerModel& m, const ArtworkOptions& o) {
  MarkerBox b;
  b.cut_half_mm = kMmPerM * (m.half_extent() + m.cell_size);
  b.font_mm = std::clamp(0.06 * b.cut_half_mm, 1.8, 4.0);
  b.label_mm = o.label ? 1.8 * b.font_mm : 0;
  return b;
}

// The directory that will hold `base`.* must exist: say so plainly before cairo fails.
// Writes the queued files together (file_io.h): all of them or, on an error, none.
Status Commit(AtomicFileSet* files, WrittenFiles* written) {
  const std::vector<std::string> paths = files->paths();
  if (Status s = files->Commit(); !s) return s;
  written->insert(written->end(), paths.begin(), paths.end());
  return Status::Ok();
}

Status CheckOutputDirectory(const std::string& base) {
  const std::filesystem::path dir = std::filesystem::path(base).parent_path();
  std::error_code ec;
  if (!dir.empty() && !std::filesystem::is_directory(dir, ec))
    return Status::Error(base + ": cannot write: directory " + dir.string() + " does not exist");
  return Status::Ok();
}

std::string StripExtension(const std::string& base) {
  for (const char* ext : {".svg", ".pdf", ".png", ".json"}) {
    const std::string e = ext;
    if (base.size() > e.size() && base.compare(base.size() - e.size(), e.size(), e) == 0)
      return base.substr(0, base.size() - e.size());
  }
  return base;
}

// Fills the ring, stripe and square of `m` centred at (cx, cy) mm (page y down). Each colour
// is one path filled once, so neighbouring cells of a colour have no antialiasing seams, and
// nothing is painted over a colour it must hide.
void DrawRing(cairo_t* cr, const MarkerModel& m, double cx, double cy, bool nested) {
  auto square = [&](double half_m) {
    const double h = kMmPerM * half_m;
    cairo_rectangle(cr, cx - h, cy - h, 2 * h, 2 * h);
  };
  auto cells = [&](bool white) {
    const uint64_t word = Svms44::Codeword(m.id);
    const double hb = 0.5 * kMmPerM * m.cell_size;
    for (int i = 0; i < Svms44::kBits; ++i) {
      if (static_cast<bool>((word >> i) & 1) != white) continue;
      const Eigen::Vector2d c = m.BitCellCentre(i);
      cairo_rectangle(cr, cx + kMmPerM * c.x() - hb, cy - kMmPerM * c.y() - hb, 2 * hb, 2 * hb);
    }
  };
  if (nested) {
    // On the outer marker's black square: paint the white parts (stripe and white cells).
    cairo_set_source_rgb(cr, 1, 1, 1);
    cells(true);
    square(0.5 * m.size + m.stripe_width);
    cairo_fill(cr);
  } else {
    // On white paper: paint the black cells.
    cairo_set_source_rgb(cr, 0, 0, 0);
    cells(false);
    cairo_fill(cr);
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  square(0.5 * m.size);
  cairo_fill(cr);
}

void DrawBitIndices(cairo_t* cr, const MarkerModel& m, double cx, double cy) {
  const uint64_t word = Svms44::Codeword(m.id);
  cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_BOLD);
  cairo_set_font_size(cr, 0.4 * kMmPerM * m.cell_size);
  for (int i = 0; i < Svms44::kBits; ++i) {
    const Eigen::Vector2d c = m.BitCellCentre(i);
    const bool white = (word >> i) & 1;
    cairo_set_source_rgb(cr, white ? 0.8 : 0.2, white ? 0.1 : 0.6, white ? 0.1 : 1.0);
    const std::string t = std::to_string(i);
    cairo_text_extents_t ext;
    cairo_text_extents(cr, t.c_str(), &ext);
    cairo_move_to(cr, cx + kMmPerM * c.x() - ext.width / 2 - ext.x_bearing,
                  cy - kMmPerM * c.y() - ext.height / 2 - ext.y_bearing);
    cairo_show_text(cr, t.c_str());
  }
}

// One marker (and its nested marker) with quiet zone, marks and label, centred at (cx, cy).
void DrawMarker(cairo_t* cr, const MarkerModel& m, double cx, double cy, const ArtworkOptions& o) {
  const MarkerBox box = BoxFor(m, o);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_rectangle(cr, cx - box.cut_half_mm, cy - box.cut_half_mm, 2 * box.cut_half_mm,
                  2 * box.cut_half_mm);
  cairo_fill(cr);
  DrawRing(cr, m, cx, cy, false);
  if (const auto inner = m.InnerModel()) DrawRing(cr, *inner, cx, cy, true);
  if (o.annotate_bits) {
    DrawBitIndices(cr, m, cx, cy);
    if (const auto inner = m.InnerModel()) DrawBitIndices(cr, *inner, cx, cy);
  }
  // Drill guide: the post's (or well's) outline and a centre cross, mid grey on black.
  const double innermost = m.inner ? m.inner->size : m.size;
  const double r = kMmPerM * (m.post ? m.post->radius : 0.05 * innermost);
  cairo_set_source_rgb(cr, 0.5, 0.5, 0.5);
  cairo_set_line_width(cr, std::clamp(0.08 * r, 0.1, 0.3));
  if (m.post) {
    cairo_new_sub_path(cr);
    cairo_arc(cr, cx, cy, r, 0, 2 * M_PI);
    cairo_stroke(cr);
  }
  cairo_move_to(cr, cx - 1.5 * r, cy);
  cairo_line_to(cr, cx + 1.5 * r, cy);
  cairo_move_to(cr, cx, cy - 1.5 * r);
  cairo_line_to(cr, cx, cy + 1.5 * r);
  cairo_stroke(cr);
  if (o.cut_marks) {
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 0.2);
    const double h = box.cut_half_mm;
    for (int sx : {-1, 1}) {
      for (int sy : {-1, 1}) {
        const double x = cx + sx * h, y = cy + sy * h;
        cairo_move_to(cr, x + sx * kCutMarkOffset, y);
        cairo_line_to(cr, x + sx * (kCutMarkOffset + kCutMarkLength), y);
        cairo_move_to(cr, x, y + sy * kCutMarkOffset);
        cairo_line_to(cr, x, y + sy * (kCutMarkOffset + kCutMarkLength));
      }
    }
    cairo_stroke(cr);
  }
  if (o.label) {
    char text[200];
    std::string post = "flat";
    if (m.post) {
      char p[64];
      std::snprintf(p, sizeof p, "%s %+.1f mm", m.post->concave() ? "well" : "post",
                    kMmPerM * m.post->height);
      post = p;
    }
    if (m.inner) {
      std::snprintf(text, sizeof text, "%s  ID %d / %d  %.1f / %.1f mm  %s", m.family.c_str(), m.id,
                    m.inner->id, kMmPerM * m.size, kMmPerM * m.inner->size, post.c_str());
    } else {
      std::snprintf(text, sizeof text, "%s  ID %d  %.1f mm  %s", m.family.c_str(), m.id,
                    kMmPerM * m.size, post.c_str());
    }
    cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, box.font_mm);
    cairo_text_extents_t ext;
    cairo_text_extents(cr, text, &ext);
    cairo_set_source_rgb(cr, 0.25, 0.25, 0.25);
    cairo_move_to(cr, cx - ext.width / 2 - ext.x_bearing,
                  cy + box.cut_half_mm + kCutMarkOffset + 1.3 * box.font_mm);
    cairo_show_text(cr, text);
  }
}

// What is drawn on one page: markers and their centres in mm; `bare` draws the rings only,
// turned by `angle` (radians, counter-clockwise as printed).
struct Placement {
  const MarkerModel* model;
  double cx, cy;
  bool bare = false;
  double angle = 0;
};
using Page = std::vector<Placement>;

void DrawBareMarker(cairo_t* cr, const Placement& p) {
  cairo_save(cr);
  cairo_translate(cr, p.cx, p.cy);
  cairo_rotate(cr, -p.angle);  // page y is down
  DrawRing(cr, *p.model, 0, 0, false);
  if (const auto inner = p.model->InnerModel()) DrawRing(cr, *inner, 0, 0, true);
  cairo_restore(cr);
}

// Draws a page of `w` x `h` mm with `draw` (user units mm, y down) into a new RGB24 image at
// `dpi`, the page centre at the image centre, dpi / 25.4 pixels per mm. *out is the caller's to
// destroy. Refuses more than 400 megapixels (`name` says which image).
Status Rasterize(const std::function<void(cairo_t*)>& draw, double w, double h, double dpi,
                 const std::string& name, cairo_surface_t** out) {
  // Drawn at exactly the resolution the PNG's pHYs chunk declares (ArtworkPixelsPerMetre): k
  // pixels per mm.
  const double k = ArtworkPixelsPerMetre(dpi) / 1000.0;
  const double wd = std::round(w * k), hd = std::round(h * k);
  if (!(wd >= 1 && hd >= 1 && wd * hd <= 4e8))
    return Status::Error(name + ": " + std::to_string(static_cast<long long>(wd)) + "x" +
                         std::to_string(static_cast<long long>(hd)) +
                         " pixels at " + std::to_string(dpi) +
                         " dpi; expected at most 400 megapixels (lower --dpi)");
  const int wp = static_cast<int>(wd), hp = static_cast<int>(hd);
  cairo_surface_t* img = cairo_image_surface_create(CAIRO_FORMAT_RGB24, wp, hp);
  cairo_t* cr = cairo_create(img);
  cairo_translate(cr, 0.5 * wp, 0.5 * hp);
  cairo_scale(cr, k, k);
  cairo_translate(cr, -0.5 * w, -0.5 * h);
  draw(cr);
  cairo_destroy(cr);
  cairo_surface_flush(img);
  if (const cairo_status_t st = cairo_surface_status(img); st != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(img);
    return Status::Error(name + ": cannot draw (" + cairo_status_to_string(st) + ")");
  }
  *out = img;
  return Status::Ok();
}

// The page of one marker's artwork: `w` x `h` mm with the marker at its centre.
void MarkerPageSize(const MarkerModel& model, const ArtworkOptions& options, double* w,
                    double* h) {
  const MarkerBox box = BoxFor(model, options);
  const double margin = 4.0;  // mm of paper around the marks
  *w = box.width() + 2 * margin;
  *h = box.width() + 2 * (box.label_mm + margin);  // symmetric: centre stays centred
}

// Renders `pages` (each `w` x `h` mm) into SVG, PDF and PNG files named from `base`.
Status RenderPages(const std::vector<Page>& pages, double w, double h, const std::string& base,
                   const ArtworkOptions& o, AtomicFileSet* files, const std::string& caption = "") {
  auto draw_page = [&](cairo_t* cr, const Page& page) {
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    for (const Placement& p : page) {
      if (p.bare) {
        DrawBareMarker(cr, p);
      } else {
        DrawMarker(cr, *p.model, p.cx, p.cy, o);
      }
    }
    if (!caption.empty()) {
      cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
      cairo_set_font_size(cr, 3.0);
      cairo_text_extents_t ext;
      cairo_text_extents(cr, caption.c_str(), &ext);
      cairo_set_source_rgb(cr, 0.25, 0.25, 0.25);
      cairo_move_to(cr, 0.5 * w - ext.width / 2 - ext.x_bearing, h - 2.0);
      cairo_show_text(cr, caption.c_str());
    }
  };
  auto check = [&](cairo_surface_t* s, const std::string& file) -> Status {
    const cairo_status_t st = cairo_surface_status(s);
    if (st != CAIRO_STATUS_SUCCESS)
      return Status::Error(file + ": cannot draw (" + cairo_status_to_string(st) + ")");
    return Status::Ok();
  };
  // Every file is drawn into memory and queued; the caller commits them together.
  std::string bytes;
  const cairo_write_func_t append = [](void* closure, const unsigned char* data,
                                       unsigned int length) {
    static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
    return CAIRO_STATUS_SUCCESS;
  };
  const bool multi = pages.size() > 1;
  auto page_name = [&](size_t i, const char* ext) {
    return multi ? base + "-" + std::to_string(i + 1) + ext : base + ext;
  };

  // PDF: one file, all pages; user units mm.
  {
    const std::string file = base + ".pdf";
    bytes.clear();
    cairo_surface_t* s =
        cairo_pdf_surface_create_for_stream(append, &bytes, w * 72 / 25.4, h * 72 / 25.4);
    cairo_t* cr = cairo_create(s);
    cairo_scale(cr, 72 / 25.4, 72 / 25.4);
    for (const Page& page : pages) {
      draw_page(cr, page);
      cairo_show_page(cr);
    }
    cairo_destroy(cr);
    cairo_surface_finish(s);
    const Status st = check(s, file);
    cairo_surface_destroy(s);
    if (!st) return st;
    files->Add(file, std::move(bytes));
  }
  for (size_t i = 0; i < pages.size(); ++i) {
    // SVG: the document unit is mm, so user units are millimetres.
    const std::string svg = page_name(i, ".svg");
    bytes.clear();
    cairo_surface_t* s = cairo_svg_surface_create_for_stream(append, &bytes, w, h);
    cairo_svg_surface_set_document_unit(s, CAIRO_SVG_UNIT_MM);
    cairo_t* cr = cairo_create(s);
    draw_page(cr, pages[i]);
    cairo_destroy(cr);
    cairo_surface_finish(s);
    Status st = check(s, svg);
    cairo_surface_destroy(s);
    if (!st) return st;
    files->Add(svg, std::move(bytes));
    if (!o.write_png) continue;
    const std::string png = page_name(i, ".png");
    cairo_surface_t* img = nullptr;
    if (Status r = Rasterize([&](cairo_t* c) { draw_page(c, pages[i]); }, w, h, o.dpi, png, &img);
        !r)
      return r;
    const std::uint32_t ppm = ArtworkPixelsPerMetre(o.dpi);
    const int wp = cairo_image_surface_get_width(img), hp = cairo_image_surface_get_height(img);
    bytes.clear();
    const Status ws = EncodePngWithResolution(png, cairo_image_surface_get_data(img), wp, hp,
                                              cairo_image_surface_get_stride(img), ppm, &bytes);
    cairo_surface_destroy(img);
    if (!ws) return ws;
    files->Add(png, std::move(bytes));
  }
  return Status::Ok();
}

}  // namespace

Status PageSpec::Parse(const std::string& name, PageSpec* out) {
  PageSpec p;
  p.name = name;
  if (name == "A4" || name == "a4") {
    p.width_mm = 210, p.height_mm = 297;
  } else if (name == "A3" || name == "a3") {
    p.width_mm = 297, p.height_mm = 420;
  } else if (name == "Letter" || name == "letter") {
    p.width_mm = 215.9, p.height_mm = 279.4;
  } else {
    double w = 0, h = 0;
    char tail = 0;
    if (std::sscanf(name.c_str(), "%lfx%lf%c", &w, &h, &tail) != 2 || !(w >= 20 && h >= 20) ||
        !(w <= 5000 && h <= 5000)) {
      return Status::Error(
          "--page: expected A4, A3, Letter or WxH in millimetres (20 to 5000), "
          "got \"" +
          name + "\"");
    }
    p.width_mm = w, p.height_mm = h;
  }
  *out = p;
  return Status::Ok();
}

Status WriteMarkerArtwork(const MarkerModel& model, const std::string& base_in,
                          const ArtworkOptions& options, WrittenFiles* written) {
  if (Status s = model.Validate(); !s) return s;
  const std::string base = StripExtension(base_in);
  if (Status s = CheckOutputDirectory(base); !s) return s;
  double w = 0, h = 0;
  MarkerPageSize(model, options, &w, &h);
  AtomicFileSet files;
  if (Status s = RenderPages({{Placement{&model, 0.5 * w, 0.5 * h}}}, w, h, base, options, &files);
      !s)
    return s;
  files.Add(base + ".json", MarkerModelToJson(model));
  return Commit(&files, written);
}

Status WriteSheet(const std::vector<MarkerModel>& models, const std::string& base_in,
                  const SheetOptions& o, WrittenFiles* written) {
  if (models.empty()) return Status::Error("sheet: expected at least one marker");
  const std::string base = StripExtension(base_in);
  if (Status s = CheckOutputDirectory(base); !s) return s;
  const double W = o.page.width_mm, H = o.page.height_mm;
  const double usable_w = W - 2 * o.margin_mm, usable_h = H - 2 * o.margin_mm;
  std::vector<Page> pages(1);
  double x = 0, y = 0, row_h = 0;
  for (const MarkerModel& m : models) {
    if (Status s = m.Validate(); !s) return s;
    const MarkerBox box = BoxFor(m, o);
    if (box.width() > usable_w || box.height() > usable_h) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "marker %d needs %.1f x %.1f mm, more than the printable %.1f x %.1f mm of "
                    "page %s; use a larger --page",
                    m.id, box.width(), box.height(), usable_w, usable_h, o.page.name.c_str());
      return Status::Error(buf);
    }
    if (x > 0 && x + box.width() > usable_w) {  // next row
      x = 0;
      y += row_h + o.gap_mm;
      row_h = 0;
    }
    if (y > 0 && y + box.height() > usable_h) {  // next page
      pages.emplace_back();
      x = y = row_h = 0;
    }
    pages.back().push_back(
        Placement{&m, o.margin_mm + x + 0.5 * box.width(), o.margin_mm + y + 0.5 * box.width()});
    x += box.width() + o.gap_mm;
    row_h = std::max(row_h, box.height());
  }
  AtomicFileSet files;
  if (Status s = RenderPages(pages, W, H, base, o, &files); !s) return s;
  files.Add(base + ".json", MarkerSetToJson(models));
  return Commit(&files, written);
}

Status WriteLayoutArtwork(const Layout& layout, const std::string& base_in,
                          const ArtworkOptions& options, double margin_mm, WrittenFiles* written) {
  if (Status s = layout.Validate(); !s) return s;
  if (!(std::isfinite(margin_mm) && margin_mm >= 0))
    return Status::Error("layout artwork: expected a non-negative margin, got " +
                         std::to_string(margin_mm) + " mm");
  const std::string base = StripExtension(base_in);
  if (Status s = CheckOutputDirectory(base); !s) return s;
  double lo_x = 1e300, hi_x = -1e300, lo_y = 1e300, hi_y = -1e300;
  Page page;
  for (size_t i = 0; i < layout.markers.size(); ++i) {
    const LayoutEntry& e = layout.markers[i];
    const Pose& p = e.object_from_marker;
    if (std::abs(p.tvec.z()) > 1e-9 || std::abs(p.rvec.x()) > 1e-9 || std::abs(p.rvec.y()) > 1e-9)
      return Status::Error("markers[" + std::to_string(i) + "] (ID " + std::to_string(e.marker.id) +
                           "): expected a marker in the layout's z = 0 plane turned about z only");
    // The outer edge of the ring, turned: its bounding box.
    const double a = p.rvec.z(), h = e.marker.half_extent();
    const double r = h * (std::abs(std::cos(a)) + std::abs(std::sin(a)));
    lo_x = std::min(lo_x, p.tvec.x() - r), hi_x = std::max(hi_x, p.tvec.x() + r);
    lo_y = std::min(lo_y, p.tvec.y() - r), hi_y = std::max(hi_y, p.tvec.y() + r);
    page.push_back(Placement{&e.marker, kMmPerM * p.tvec.x(), -kMmPerM * p.tvec.y(), true, a});
  }
  // Symmetric about the origin, so the page centre is the layout origin.
  const double half_w = kMmPerM * std::max(std::abs(lo_x), std::abs(hi_x)) + margin_mm;
  const double half_h = kMmPerM * std::max(std::abs(lo_y), std::abs(hi_y)) + margin_mm;
  const double caption_mm = options.label ? 6.0 : 0.0;
  const double w = 2 * half_w, h = 2 * (half_h + caption_mm);
  for (Placement& p : page) p.cx += 0.5 * w, p.cy += 0.5 * h;
  AtomicFileSet files;
  if (Status s = RenderPages({page}, w, h, base, options, &files,
                             options.label ? layout.name : std::string());
      !s)
    return s;
  files.Add(base + ".json", LayoutToJson(layout));
  return Commit(&files, written);
}

std::uint32_t ArtworkPixelsPerMetre(double dpi) {
  const double ppm = std::round(dpi / 0.0254);
  return ppm < 1 ? 1 : ppm > 4e9 ? 4000000000u : static_cast<std::uint32_t>(ppm);
}

Status RenderMarkerImage(const MarkerModel& model, const ArtworkOptions& options,
                         std::vector<uint8_t>* grey, int* width, int* height) {
  if (Status s = model.Validate(); !s) return s;
  if (!(options.dpi > 0 && std::isfinite(options.dpi)))
    return Status::Error("dpi: expected a positive number, got " + std::to_string(options.dpi));
  double w = 0, h = 0;
  MarkerPageSize(model, options, &w, &h);
  cairo_surface_t* img = nullptr;
  const auto draw = [&](cairo_t* cr) {
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    DrawMarker(cr, model, 0.5 * w, 0.5 * h, options);
  };
  if (Status s = Rasterize(draw, w, h, options.dpi, "marker " + std::to_string(model.id), &img);
      !s)
    return s;
  const int wp = cairo_image_surface_get_width(img), hp = cairo_image_surface_get_height(img);
  const int stride = cairo_image_surface_get_stride(img);
  const unsigned char* data = cairo_image_surface_get_data(img);
  grey->resize(static_cast<size_t>(wp) * hp);
  // RGB24 keeps each pixel in a native-endian uint32 (0x00RRGGBB); everything is drawn in grey,
  // so green is the grey level.
  for (int y = 0; y < hp; ++y) {
    const auto* row = reinterpret_cast<const uint32_t*>(data + static_cast<size_t>(y) * stride);
    for (int x = 0; x < wp; ++x) (*grey)[static_cast<size_t>(y) * wp + x] = (row[x] >> 8) & 0xff;
  }
  cairo_surface_destroy(img);
  *width = wp;
  *height = hp;
  return Status::Ok();
}

Eigen::Matrix3d ArtworkPixelFromPlane(int width, int height, double dpi) {
  const double k = ArtworkPixelsPerMetre(dpi);  // pixels per metre
  Eigen::Matrix3d H;
  H << k, 0, 0.5 * (width - 1), 0, -k, 0.5 * (height - 1), 0, 0, 1;
  return H;
}

}  // namespace svms
