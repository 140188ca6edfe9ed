// svms.MarkerModel, svms.Layout and the model files (docs/markers.md): what the detector, the
// pose estimator and the artwork read.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "svms/marker/layout.h"
#include "svms/marker/marker_model.h"
#include "svms/marker/model_io.h"

namespace svms::python {
namespace {

ModelFile ReadModels(const std::filesystem::path& path) {
  const std::string p = path.string();
  RaiseIfMissing(p, "a marker model, marker set or layout JSON file");
  ModelFile f;
  RaiseIfError(ReadModelFile(p, &f));
  return f;
}

Eigen::Matrix<double, 4, 3, Eigen::RowMajor> CornersOf(const MarkerModel& m) {
  Eigen::Matrix<double, 4, 3, Eigen::RowMajor> c;
  const auto corners = m.Corners();
  for (int k = 0; k < 4; ++k) c.row(k) = corners[k].transpose();
  return c;
}

}  // namespace

void BindMarkers(py::module_& m) {
  py::class_<PostModel>(m, "PostModel",
                        "The post at a marker's centre: height > 0 protrudes (white top), < 0 is a "
                        "concave well (white bottom); metres.")
      .def(py::init<>())
      .def_readwrite("height", &PostModel::height)
      .def_readwrite("radius", &PostModel::radius)
      .def_readwrite("tip_radius", &PostModel::tip_radius)
      .def_property_readonly("concave", &PostModel::concave);

  py::class_<NestedMarker>(m, "NestedMarker", "A dual marker's inner marker (metres)")
      .def(py::init<>())
      .def_readwrite("id", &NestedMarker::id)
      .def_readwrite("size", &NestedMarker::size)
      .def_readwrite("stripe_width", &NestedMarker::stripe_width)
      .def_readwrite("cell_size", &NestedMarker::cell_size);

  py::class_<MarkerModel>(m, "MarkerModel",
                          "One SVMS marker's geometry (metres, marker frame: origin at the centre "
                          "of the black square, x right, y up as printed, z toward the viewer).")
      .def(py::init<>())
      .def_static("standard", &MarkerModel::Standard, py::arg("id"), py::arg("size"),
                  py::arg("post_height"),
                  "The standard proportions: cell = size / 6, stripe = 2 cells; a post of "
                  "`post_height` metres (0: none, < 0: a concave well).")
      .def("add_inner", &MarkerModel::AddInner, py::arg("inner_id"), py::arg("inner_size"),
           "Nests a marker of the standard proportions in the black square (a dual marker).")
      .def_readwrite("family", &MarkerModel::family)
      .def_readwrite("id", &MarkerModel::id)
      .def_readwrite("size", &MarkerModel::size, "side of the black square, metres")
      .def_readwrite("stripe_width", &MarkerModel::stripe_width, "metres")
      .def_readwrite("cell_size", &MarkerModel::cell_size, "side of a bit cell, metres")
      .def_readwrite("post", &MarkerModel::post, "PostModel or None")
      .def_readwrite("inner", &MarkerModel::inner, "NestedMarker or None")
      .def_property_readonly("corners", &CornersOf,
                             "the black square's corners in the marker frame, 4 x 3 (TL, TR, BR, "
                             "BL as printed)")
      .def_property_readonly("post_tip", &MarkerModel::PostTip, "(3,) or None")
      .def_property_readonly("half_extent", &MarkerModel::half_extent,
                             "half the side of the whole marker (the bit ring's outer edge)")
      .def("inner_model", &MarkerModel::InnerModel, "the inner marker as a MarkerModel, or None")
      .def(
          "validate", [](const MarkerModel& mm) { RaiseIfError(mm.Validate()); },
          "raises ValueError naming the field that is wrong")
      .def("to_json", &MarkerModelToJson, "the svms.marker JSON text")
      .def("__repr__",
           [](const MarkerModel& mm) { return "<svms.MarkerModel " + mm.Summary() + ">"; });

  py::class_<LayoutEntry>(m, "LayoutEntry",
                          "A marker fixed on the object: its model, object_from_marker and, once "
                          "surveyed, that pose's 6 x 6 covariance ([rotation, translation], "
                          "object axes; rad^2, m^2) or None.")
      .def(py::init<>())
      .def_readwrite("marker", &LayoutEntry::marker)
      .def_readwrite("object_from_marker", &LayoutEntry::object_from_marker)
      .def_readwrite("covariance", &LayoutEntry::covariance)
      .def_readwrite("post_height_sigma", &LayoutEntry::post_height_sigma, "metres or None");

  py::class_<Layout>(m, "Layout", "Markers fixed on one object (svms survey's layout.json)")
      .def(py::init<>())
      .def_readwrite("name", &Layout::name)
      .def_readwrite("markers", &Layout::markers, "list of LayoutEntry (a copy when read)")
      .def(
          "find",
          [](const Layout& l, int id) -> std::optional<LayoutEntry> {
            const LayoutEntry* e = l.Find(id);
            if (!e) return std::nullopt;
            return *e;
          },
          py::arg("id"), "the entry whose outer or inner marker has this ID, or None")
      .def(
          "validate", [](const Layout& l) { RaiseIfError(l.Validate()); },
          "raises ValueError on invalid markers, duplicate IDs, overlaps")
      .def("to_json", &LayoutToJson, "the svms.layout JSON text")
      .def("__repr__", [](const Layout& l) { return "<svms.Layout " + l.Summary() + ">"; });

  m.def(
      "read_markers",
      [](const std::filesystem::path& path) { return ReadModels(path).markers; }, py::arg("path"),
      "The marker models of a model file (svms.marker, svms.markers, or a layout's markers), "
      "checked. OSError for a missing file, ValueError naming the file and field otherwise.");
  m.def(
      "read_layout",
      [](const std::filesystem::path& path) {
        ModelFile f = ReadModels(path);
        if (f.kind != ModelFile::Kind::kLayout)
          throw py::value_error(path.string() + ": expected a layout (\"type\": \"svms.layout\"), got " +
                                f.Summary());
        return f.layout;
      },
      py::arg("path"), "A layout file (svms.layout), checked.");
}

}  // namespace svms::python
