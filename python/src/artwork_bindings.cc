// Marker artwork as numpy arrays (print/artwork.h): the picture `svms generate marker` writes as
// its PNG, drawn in memory.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>

#include <memory>
#include <vector>

#include "bindings.h"
#include "svms/print/artwork.h"

namespace svms::python {

void BindArtwork(py::module_& m) {
  m.def(
      "marker_image",
      [](const MarkerModel& model, double dpi, bool label, bool cut_marks, bool annotate_bits) {
        ArtworkOptions o;
        o.dpi = dpi;
        o.label = label;
        o.cut_marks = cut_marks;
        o.annotate_bits = annotate_bits;
        auto grey = std::make_unique<std::vector<uint8_t>>();
        int w = 0, h = 0;
        Status s;
        {
          py::gil_scoped_release release;
          s = RenderMarkerImage(model, o, grey.get(), &w, &h);
        }
        RaiseIfError(s);
        // The array owns the rendered buffer (no copy).
        uint8_t* data = grey->data();
        py::capsule owner(grey.release(),
                          [](void* p) { delete static_cast<std::vector<uint8_t>*>(p); });
        return py::array_t<uint8_t>({static_cast<py::ssize_t>(h), static_cast<py::ssize_t>(w)},
                                    data, owner);
      },
      py::arg("model"), py::arg("dpi") = 300.0, py::arg("label") = true,
      py::arg("cut_marks") = true, py::arg("annotate_bits") = false,
      "The printable artwork of one marker as an H x W uint8 array (0 black, 255 white), the "
      "picture `svms generate marker` writes as its PNG: one bit cell of white around the ring, "
      "cut marks, a label below. The marker's centre is at ((W - 1) / 2, (H - 1) / 2); one metre "
      "is dpi / 0.0254 pixels (artwork_pixel_from_plane).");
  m.def("artwork_pixel_from_plane", &ArtworkPixelFromPlane, py::arg("width"), py::arg("height"),
        py::arg("dpi"),
        "The 3 x 3 homography from the marker plane (metres, x right, y up) to pixels of a "
        "marker_image of width x height pixels at dpi.");
}

}  // namespace svms::python
