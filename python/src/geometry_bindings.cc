// svms.Pose: a rigid transform a_from_b (p_a = R p_b + t) as a rotation vector and a
// translation, docs/conventions.md.
#include <pybind11/eigen.h>
#include <pybind11/operators.h>

#include <sstream>

#include "bindings.h"
#include "svms/geometry/pose.h"

namespace svms::python {

void BindGeometry(py::module_& m) {
  py::class_<Pose>(m, "Pose",
                   "A rigid transform named a_from_b: p_a = R p_b + t. rvec: rotation vector "
                   "(axis * angle, radians, shape (3,)); tvec: translation (metres, shape (3,)).")
      .def(py::init([](const Eigen::Vector3d& rvec, const Eigen::Vector3d& tvec) {
             return Pose{rvec, tvec};
           }),
           py::arg("rvec") = Eigen::Vector3d::Zero(), py::arg("tvec") = Eigen::Vector3d::Zero())
      .def_readwrite("rvec", &Pose::rvec, "rotation vector, radians, shape (3,)")
      .def_readwrite("tvec", &Pose::tvec, "translation, metres, shape (3,)")
      .def_property_readonly("rotation", &Pose::Rotation, "rotation matrix R, 3 x 3")
      .def_property_readonly(
          "matrix",
          [](const Pose& p) {
            Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
            T.topLeftCorner<3, 3>() = p.Rotation();
            T.topRightCorner<3, 1>() = p.tvec;
            return T;
          },
          "the 4 x 4 homogeneous matrix [R t; 0 0 0 1]")
      .def_static(
          "from_matrix",
          [](const Eigen::MatrixXd& T) {
            if (!((T.rows() == 4 || T.rows() == 3) && T.cols() == 4) || !T.allFinite())
              throw py::value_error("from_matrix: expected a finite 4 x 4 (or 3 x 4) matrix [R t], got " +
                                    std::to_string(T.rows()) + " x " + std::to_string(T.cols()));
            const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
            if (!(R.transpose() * R - Eigen::Matrix3d::Identity()).isZero(1e-6) || R.determinant() < 0)
              throw py::value_error("from_matrix: the 3 x 3 block is not a rotation (R^T R != I within 1e-6, or det < 0)");
            return Pose::FromRotation(R, T.topRightCorner<3, 1>());
          },
          py::arg("matrix"), "a Pose from a 4 x 4 (or 3 x 4) [R t] whose R is a rotation")
      .def("inverse", &Pose::Inverse, "b_from_a for this a_from_b")
      .def("transform",
           [](const Pose& p, const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>& pts) {
             Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> out(pts.rows(), 3);
             const Eigen::Matrix3d R = p.Rotation();
             for (Eigen::Index i = 0; i < pts.rows(); ++i)
               out.row(i) = (R * pts.row(i).transpose() + p.tvec).transpose();
             return out;
           },
           py::arg("points"), "points of frame b (N x 3, metres) in frame a")
      .def(py::self * py::self, "a_from_b * b_from_c = a_from_c")
      .def("__repr__", [](const Pose& p) {
        std::ostringstream s;
        s.precision(6);
        s << "Pose(rvec=[" << p.rvec(0) << ", " << p.rvec(1) << ", " << p.rvec(2) << "], tvec=["
          << p.tvec(0) << ", " << p.tvec(1) << ", " << p.tvec(2) << "])";
        return s.str();
      });
}

}  // namespace svms::python
