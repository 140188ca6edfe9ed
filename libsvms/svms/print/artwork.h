// Printable artwork of SVMS markers, drawn with cairo at exact physical scale: SVG (user
// units are millimetres), PDF (points, 1/72 inch) and PNG (at a chosen resolution).
//
// Each marker is drawn with a white quiet zone of one bit cell around its ring, cut marks
// outside that, a small label (family, ID, size, post) below it, and a centre cross with the
// post's (or the well's) outline for drilling. In the PNG of a single marker, the marker's
// centre is at the image centre, ((W - 1) / 2, (H - 1) / 2) in pixel-centre coordinates, and
// one metre is ArtworkPixelsPerMetre(dpi) pixels: ArtworkPixelFromPlane gives that mapping.
//
// The PDF (and the SVG) is the printed reference: vector, at exact physical size. The PNG
// carries its resolution in a pHYs chunk (pixels per metre, the unit PNG has), and is drawn at
// exactly that resolution: printed at its declared resolution, every length in it is its
// physical length. Its width and height are the page's rounded to whole pixels (the page
// centre stays at the image centre).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/marker/layout.h"
#include "svms/marker/marker_model.h"

namespace svms {

struct ArtworkOptions {
  double dpi = 300;   // PNG resolution, pixels per inch
  bool label = true;  // family, ID, size and post printed below the marker
  bool cut_marks = true;
  bool annotate_bits = false;  // print each cell's bit index (for documentation)
  bool write_png = true;
};

struct PageSpec {
  std::string name = "A4";  // "A4", "Letter", or "WxH" in millimetres, e.g. "300x200"
  double width_mm = 210, height_mm = 297;
  // Parses a page name; false (with a message) on a bad one.
  static Status Parse(const std::string& name, PageSpec* out);
};

struct SheetOptions : ArtworkOptions {
  PageSpec page;
  double margin_mm = 10;  // unprinted border of the page
  double gap_mm = 6;      // between markers' cut boxes
};

// Files written, in order. Every writer below draws all its files in memory first and writes
// them as a group (AtomicFileSet, file_io.h): on any error none is written or replaced, and
// files of an earlier run stay as they were.
using WrittenFiles = std::vector<std::string>;

// Writes BASE.svg, BASE.pdf, BASE.png (unless !write_png) and BASE.json (the model).
// `base` may carry one of those extensions; it is stripped.
Status WriteMarkerArtwork(const MarkerModel& model, const std::string& base,
                          const ArtworkOptions& options, WrittenFiles* written);

// Lays the markers out on pages (rows, left to right); writes BASE.pdf (all pages),
// BASE.svg / BASE.png (or BASE-N.svg / BASE-N.png per page when there are several) and
// BASE.json (an svms.markers set). Fails, writing nothing, if a marker does not fit a page.
Status WriteSheet(const std::vector<MarkerModel>& models, const std::string& base,
                  const SheetOptions& options, WrittenFiles* written);

// Writes a planar layout (e.g. a calibration board, calib/board.h) at exact scale on one page:
// BASE.svg, BASE.pdf, BASE.png (unless !write_png) and BASE.json (the layout, model_io.h).
// Every marker must lie in the layout's z = 0 plane, turned about z only; the page centre is
// the layout origin, x right and y up as printed, with `margin_mm` of white around the markers'
// outer edges. Only the markers' rings and squares are drawn (no per-marker cut marks or
// labels: neighbours may be closer than those need); `options.label` prints one caption line
// with the layout's name below the markers. Errors name the marker that is not planar.
Status WriteLayoutArtwork(const Layout& layout, const std::string& base,
                          const ArtworkOptions& options, double margin_mm, WrittenFiles* written);

// The resolution the PNG artwork is drawn at and declares (pHYs): `dpi` as a whole number of
// pixels per metre, round(dpi / 0.0254) (at least 1), because pHYs holds an integer; 300 dpi
// is 11811 pixels per metre (299.9994 dpi), 254 dpi exactly 10000.
std::uint32_t ArtworkPixelsPerMetre(double dpi);

// The single-marker PNG that WriteMarkerArtwork writes (unless !write_png), drawn in memory:
// *grey gets *height rows of *width pixels, row-major, 0 black to 255 white (the artwork has no
// colour), the marker's centre at ((W - 1) / 2, (H - 1) / 2) (ArtworkPixelFromPlane). Errors:
// an invalid model (MarkerModel::Validate), a dpi that is not positive, over 400 megapixels.
Status RenderMarkerImage(const MarkerModel& model, const ArtworkOptions& options,
                         std::vector<uint8_t>* grey, int* width, int* height);

// The homography from the marker plane (metres) to pixels of the single-marker PNG of an
// image of `width` x `height` pixels at `dpi` (ArtworkPixelsPerMetre(dpi) pixels per metre).
Eigen::Matrix3d ArtworkPixelFromPlane(int width, int height, double dpi);

}  // namespace svms
