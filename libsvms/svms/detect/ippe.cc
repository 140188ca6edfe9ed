// Port of OpenCV 4.6's IPPE for squares (modules/calib3d/src/ippe.cpp, Copyright 2017 Toby
// Collins, BSD 3-clause; OpenCV, Apache 2.0). See ippe.h. The expressions keep OpenCV's
// operation order so that the results agree to rounding; comments name the OpenCV function.
#include "svms/detect/ippe.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace svms {
namespace {

// PoseSolver::homographyFromSquarePoints: the homography H (H(2,2) = 1) taking the canonical
// square (-h, h), (h, h), (h, -h), (-h, -h) to the four points. *det is OpenCV's determinant
// h * cross(p0 - p2, p1 - p3); false where OpenCV throws "Determinant is zero!".
bool HomographyFromSquarePoints(const std::array<Eigen::Vector2d, 4>& pts, double halfLength,
                                Eigen::Matrix3d* Hout) {
  const double p1x = -pts[0].x(), p1y = -pts[0].y();
  const double p2x = -pts[1].x(), p2y = -pts[1].y();
  const double p3x = -pts[2].x(), p3y = -pts[2].y();
  const double p4x = -pts[3].x(), p4y = -pts[3].y();

  const double det = (halfLength * (p1x * p2y - p2x * p1y - p1x * p4y + p2x * p3y - p3x * p2y +
                                    p4x * p1y + p3x * p4y - p4x * p3y));
  if (std::abs(det) < 1e-9) return false;
  const double detsInv = -1 / det;

  Eigen::Matrix3d& H = *Hout;
  H(0, 0) = detsInv * (p1x * p3x * p2y - p2x * p3x * p1y - p1x * p4x * p2y + p2x * p4x * p1y -
                       p1x * p3x * p4y + p1x * p4x * p3y + p2x * p3x * p4y - p2x * p4x * p3y);
  H(0, 1) = detsInv * (p1x * p2x * p3y - p1x * p3x * p2y - p1x * p2x * p4y + p2x * p4x * p1y +
                       p1x * p3x * p4y - p3x * p4x * p1y - p2x * p4x * p3y + p3x * p4x * p2y);
  H(0, 2) = detsInv * halfLength *
            (p1x * p2x * p3y - p2x * p3x * p1y - p1x * p2x * p4y + p1x * p4x * p2y -
             p1x * p4x * p3y + p3x * p4x * p1y + p2x * p3x * p4y - p3x * p4x * p2y);
  H(1, 0) = detsInv * (p1x * p2y * p3y - p2x * p1y * p3y - p1x * p2y * p4y + p2x * p1y * p4y -
                       p3x * p1y * p4y + p4x * p1y * p3y + p3x * p2y * p4y - p4x * p2y * p3y);
  H(1, 1) = detsInv * (p2x * p1y * p3y - p3x * p1y * p2y - p1x * p2y * p4y + p4x * p1y * p2y +
                       p1x * p3y * p4y - p4x * p1y * p3y - p2x * p3y * p4y + p3x * p2y * p4y);
  H(1, 2) = detsInv * halfLength *
            (p1x * p2y * p3y - p3x * p1y * p2y - p2x * p1y * p4y + p4x * p1y * p2y -
             p1x * p3y * p4y + p3x * p1y * p4y + p2x * p3y * p4y - p4x * p2y * p3y);
  H(2, 0) = -detsInv * (p1x * p3y - p3x * p1y - p1x * p4y - p2x * p3y + p3x * p2y + p4x * p1y +
                        p2x * p4y - p4x * p2y);
  H(2, 1) = detsInv * (p1x * p2y - p2x * p1y - p1x * p3y + p3x * p1y + p2x * p4y - p4x * p2y -
                       p3x * p4y + p4x * p3y);
  H(2, 2) = 1.0;
  return true;
}

// PoseSolver::rotateVec2ZAxis: a rotation taking the direction of a to the z axis.
Eigen::Matrix3d RotateVec2ZAxis(double ax, double ay, double az) {
  const double nrm = std::sqrt(ax * ax + ay * ay + az * az);
  ax = ax / nrm;
  ay = ay / nrm;
  az = az / nrm;
  const double c = az;
  Eigen::Matrix3d Ra;
  if (std::abs(1.0 + c) < std::numeric_limits<float>::epsilon()) {
    // Never taken from computeRotations (a = (p, q, 1)), kept as in OpenCV.
    Ra << 1.0, 0, 0, 0, 1.0, 0, 0, 0, -1.0;
  } else {
    const double d = 1.0 / (1.0 + c);
    const double ax2 = ax * ax, ay2 = ay * ay, axay = ax * ay;
    Ra(0, 0) = -ax2 * d + 1.0;
    Ra(0, 1) = -axay * d;
    Ra(0, 2) = -ax;
    Ra(1, 0) = -axay * d;
    Ra(1, 1) = -ay2 * d + 1.0;
    Ra(1, 2) = -ay;
    Ra(2, 0) = ax;
    Ra(2, 1) = ay;
    Ra(2, 2) = 1.0 - (ax2 + ay2) * d;
  }
  return Ra;
}

// PoseSolver::computeRotations: the two rotations from the Jacobian J of the homography at the
// square's centre and the centre's image (p, q). False where OpenCV throws "gamma is zero.".
bool ComputeRotations(double j00, double j01, double j10, double j11, double p, double q,
                      Eigen::Matrix3d* R1, Eigen::Matrix3d* R2) {
  const Eigen::Matrix3d Rv = RotateVec2ZAxis(p, q, 1).transpose();

  // Setup of the 2x2 SVD decomposition.
  const double rv00 = Rv(0, 0), rv01 = Rv(0, 1), rv02 = Rv(0, 2);
  const double rv10 = Rv(1, 0), rv11 = Rv(1, 1), rv12 = Rv(1, 2);
  const double rv20 = Rv(2, 0), rv21 = Rv(2, 1), rv22 = Rv(2, 2);

  const double b00 = rv00 - p * rv20;
  const double b01 = rv01 - p * rv21;
  const double b10 = rv10 - q * rv20;
  const double b11 = rv11 - q * rv21;

  const double dtinv = 1.0 / ((b00 * b11 - b01 * b10));

  const double binv00 = dtinv * b11;
  const double binv01 = -dtinv * b01;
  const double binv10 = -dtinv * b10;
  const double binv11 = dtinv * b00;

  const double a00 = binv00 * j00 + binv01 * j10;
  const double a01 = binv00 * j01 + binv01 * j11;
  const double a10 = binv10 * j00 + binv11 * j10;
  const double a11 = binv10 * j01 + binv11 * j11;

  // The largest singular value of A.
  const double ata00 = a00 * a00 + a01 * a01;
  const double ata01 = a00 * a10 + a01 * a11;
  const double ata11 = a10 * a10 + a11 * a11;

  const double gamma2 =
      0.5 * (ata00 + ata11 + std::sqrt((ata00 - ata11) * (ata00 - ata11) + 4.0 * ata01 * ata01));
  if (!(gamma2 >= 0)) return false;  // OpenCV: "gamma2 is negative." (NaN passes there)
  const double gamma = std::sqrt(gamma2);
  if (std::fabs(gamma) < std::numeric_limits<float>::epsilon()) return false;

  // The full rotation matrices.
  const double rtilde00 = a00 / gamma;
  const double rtilde01 = a01 / gamma;
  const double rtilde10 = a10 / gamma;
  const double rtilde11 = a11 / gamma;

  const double rtilde00_2 = rtilde00 * rtilde00;
  const double rtilde01_2 = rtilde01 * rtilde01;
  const double rtilde10_2 = rtilde10 * rtilde10;
  const double rtilde11_2 = rtilde11 * rtilde11;

  // Departure from OpenCV: the columns of A / gamma have norm <= 1, but by rounding can exceed
  // it by an ulp where the two singular values are equal (fronto-parallel); OpenCV then takes
  // the square root of a negative number (NaN), here 0.
  double b0 = std::sqrt(std::max(0.0, -rtilde00_2 - rtilde10_2 + 1));
  double b1 = std::sqrt(std::max(0.0, -rtilde01_2 - rtilde11_2 + 1));
  const double sp = (-rtilde00 * rtilde01 - rtilde10 * rtilde11);
  if (sp < 0) b1 = -b1;

  const double c0 = b1 * rtilde10 - b0 * rtilde11;
  const double c1 = b0 * rtilde01 - b1 * rtilde00;
  const double c2 = rtilde00 * rtilde11 - rtilde01 * rtilde10;
  const double d0 = b0 * rtilde11 - b1 * rtilde10;
  const double d1 = b1 * rtilde00 - b0 * rtilde01;

  Eigen::Matrix3d& A = *R1;
  A(0, 0) = (rtilde00)*rv00 + (rtilde10)*rv01 + (b0)*rv02;
  A(0, 1) = (rtilde01)*rv00 + (rtilde11)*rv01 + (b1)*rv02;
  A(0, 2) = c0 * rv00 + c1 * rv01 + c2 * rv02;
  A(1, 0) = (rtilde00)*rv10 + (rtilde10)*rv11 + (b0)*rv12;
  A(1, 1) = (rtilde01)*rv10 + (rtilde11)*rv11 + (b1)*rv12;
  A(1, 2) = c0 * rv10 + c1 * rv11 + c2 * rv12;
  A(2, 0) = (rtilde00)*rv20 + (rtilde10)*rv21 + (b0)*rv22;
  A(2, 1) = (rtilde01)*rv20 + (rtilde11)*rv21 + (b1)*rv22;
  A(2, 2) = c0 * rv20 + c1 * rv21 + c2 * rv22;

  Eigen::Matrix3d& B = *R2;
  B(0, 0) = (rtilde00)*rv00 + (rtilde10)*rv01 + (-b0) * rv02;
  B(0, 1) = (rtilde01)*rv00 + (rtilde11)*rv01 + (-b1) * rv02;
  B(0, 2) = d0 * rv00 + d1 * rv01 + c2 * rv02;
  B(1, 0) = (rtilde00)*rv10 + (rtilde10)*rv11 + (-b0) * rv12;
  B(1, 1) = (rtilde01)*rv10 + (rtilde11)*rv11 + (-b1) * rv12;
  B(1, 2) = d0 * rv10 + d1 * rv11 + c2 * rv12;
  B(2, 0) = (rtilde00)*rv20 + (rtilde10)*rv21 + (-b0) * rv22;
  B(2, 1) = (rtilde01)*rv20 + (rtilde11)*rv21 + (-b1) * rv22;
  B(2, 2) = d0 * rv20 + d1 * rv21 + c2 * rv22;
  return true;
}

// PoseSolver::computeTranslation: the least-squares translation for rotation R, from the
// normal equations of the linearised projection of the object points (x, y, 0).
Eigen::Vector3d ComputeTranslation(const std::array<Eigen::Vector2d, 4>& objectPoints,
                                   const std::array<Eigen::Vector2d, 4>& imgPoints,
                                   const Eigen::Matrix3d& R) {
  const double n = 4;
  // Coefficients of transpose(A) * A.
  const double ATA00 = n;
  double ATA02 = 0;
  const double ATA11 = n;
  double ATA12 = 0;
  double ATA20 = 0;
  double ATA21 = 0;
  double ATA22 = 0;
  // Coefficients of transpose(A) * b.
  double ATb0 = 0;
  double ATb1 = 0;
  double ATb2 = 0;

  for (int i = 0; i < 4; i++) {
    const Eigen::Vector2d& objPt = objectPoints[i];
    const double rx = R(0, 0) * objPt(0) + R(0, 1) * objPt(1);
    const double ry = R(1, 0) * objPt(0) + R(1, 1) * objPt(1);
    const double rz = R(2, 0) * objPt(0) + R(2, 1) * objPt(1);

    const double a2 = -imgPoints[i](0);
    const double b2 = -imgPoints[i](1);

    ATA02 = ATA02 + a2;
    ATA12 = ATA12 + b2;
    ATA20 = ATA20 + a2;
    ATA21 = ATA21 + b2;
    ATA22 = ATA22 + a2 * a2 + b2 * b2;

    const double bx = -a2 * rz - rx;
    const double by = -b2 * rz - ry;

    ATb0 = ATb0 + bx;
    ATb1 = ATb1 + by;
    ATb2 = ATb2 + a2 * bx + b2 * by;
  }

  const double detAInv =
      1.0 / (ATA00 * ATA11 * ATA22 - ATA00 * ATA12 * ATA21 - ATA02 * ATA11 * ATA20);

  // S gives inv(transpose(A) * A) / det(A)^2.
  const double S00 = ATA11 * ATA22 - ATA12 * ATA21;
  const double S01 = ATA02 * ATA21;
  const double S02 = -ATA02 * ATA11;
  const double S10 = ATA12 * ATA20;
  const double S11 = ATA00 * ATA22 - ATA02 * ATA20;
  const double S12 = -ATA00 * ATA12;
  const double S20 = -ATA11 * ATA20;
  const double S21 = -ATA00 * ATA21;
  const double S22 = ATA00 * ATA11;

  return Eigen::Vector3d(detAInv * (S00 * ATb0 + S01 * ATb1 + S02 * ATb2),
                         detAInv * (S10 * ATb0 + S11 * ATb1 + S12 * ATb2),
                         detAInv * (S20 * ATb0 + S21 * ATb1 + S22 * ATb2));
}

// The corners' reprojection for pose (R, t), as cv::projectPoints with identity intrinsics
// computes it (x = X * (1 / Z)). *err_float is PoseSolver::evalReprojError's float RMS (what
// OpenCV sorts by); the return value is the same RMS in double (solvePnPGeneric's output).
// *in_front: every corner at positive depth.
double ReprojectionError(const std::array<Eigen::Vector2d, 4>& objectPoints,
                         const std::array<Eigen::Vector2d, 4>& imgPoints, const Eigen::Matrix3d& R,
                         const Eigen::Vector3d& t, float* err_float, bool* in_front) {
  float err = 0;
  double ss = 0;
  *in_front = true;
  for (int i = 0; i < 4; i++) {
    const double X = objectPoints[i].x(), Y = objectPoints[i].y();
    const double x = R(0, 0) * X + R(0, 1) * Y + t(0);
    const double y = R(1, 0) * X + R(1, 1) * Y + t(1);
    const double z = R(2, 0) * X + R(2, 1) * Y + t(2);
    if (!(z > 0)) *in_front = false;
    const double iz = z ? 1. / z : 1;  // as cv::projectPoints
    const double ddx = x * iz - imgPoints[i].x();
    const double ddy = y * iz - imgPoints[i].y();
    const float dx = static_cast<float>(ddx);
    const float dy = static_cast<float>(ddy);
    err += dx * dx + dy * dy;
    ss += ddx * ddx + ddy * ddy;
  }
  *err_float = std::sqrt(err / (2.0f * 4));
  return std::sqrt(ss) / std::sqrt(8.0);
}

bool Finite(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  return R.allFinite() && t.allFinite();
}

}  // namespace

const char* IppeStatusName(IppeStatus status) {
  switch (status) {
    case IppeStatus::kOk:
      return "ok";
    case IppeStatus::kInvalidSide:
      return "invalid side";
    case IppeStatus::kNonFiniteInput:
      return "non-finite input";
    case IppeStatus::kBelowOpenCvDeterminant:
      return "determinant below OpenCV's threshold";
    case IppeStatus::kDegenerate:
      return "degenerate quadrilateral";
    case IppeStatus::kBelowOpenCvScale:
      return "scale below OpenCV's threshold";
    case IppeStatus::kNumericalFailure:
      return "numerical failure";
  }
  return "unknown";
}

bool SolveSquareIppe(const std::array<Eigen::Vector2d, 4>& normalized, double side,
                     std::array<PlanarPoseCandidate, 2>* out, IppeStatus* status) {
  IppeStatus dummy;
  IppeStatus& st = status ? *status : dummy;
  st = IppeStatus::kOk;
  if (!std::isfinite(side) || !(side > 0)) {
    st = IppeStatus::kInvalidSide;
    return false;
  }
  for (const auto& p : normalized)
    if (!p.allFinite()) {
      st = IppeStatus::kNonFiniteInput;
      return false;
    }

  // PoseSolver::solveSquare: the object points as OpenCV's generateSquareObjectCorners2D.
  const double halfLength = side / 2.0;
  const std::array<Eigen::Vector2d, 4> objectPoints = {
      Eigen::Vector2d(-halfLength, halfLength), Eigen::Vector2d(halfLength, halfLength),
      Eigen::Vector2d(halfLength, -halfLength), Eigen::Vector2d(-halfLength, -halfLength)};

  Eigen::Matrix3d H;
  if (!HomographyFromSquarePoints(normalized, halfLength, &H)) {
    st = IppeStatus::kBelowOpenCvDeterminant;
    return false;
  }

  // Not in OpenCV: where three corners are collinear (or two coincide) no homography maps the
  // square onto them, and OpenCV's closed form returns a singular H and meaningless, often NaN,
  // poses. The test is on the area of each triangle of three corners relative to the square of
  // the quadrilateral's largest extent, so it does not depend on scale.
  double extent2 = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      extent2 = std::max(extent2, (normalized[i] - normalized[j]).squaredNorm());
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d e0 = normalized[i] - normalized[(i + 3) % 4];
    const Eigen::Vector2d e1 = normalized[(i + 1) % 4] - normalized[i];
    if (!(std::abs(e0.x() * e1.y() - e0.y() * e1.x()) > 1e-9 * extent2)) {
      st = IppeStatus::kDegenerate;
      return false;
    }
  }

  // PoseSolver::solveCanonicalForm: the Jacobian of the homography at (0, 0) and the image of
  // (0, 0).
  const double j00 = H(0, 0) - H(2, 0) * H(0, 2);
  const double j01 = H(0, 1) - H(2, 1) * H(0, 2);
  const double j10 = H(1, 0) - H(2, 0) * H(1, 2);
  const double j11 = H(1, 1) - H(2, 1) * H(1, 2);
  const double v0 = H(0, 2);
  const double v1 = H(1, 2);

  Eigen::Matrix3d Ra, Rb;
  if (!ComputeRotations(j00, j01, j10, j11, v0, v1, &Ra, &Rb)) {
    st = IppeStatus::kBelowOpenCvScale;
    return false;
  }
  const Eigen::Vector3d ta = ComputeTranslation(objectPoints, normalized, Ra);
  const Eigen::Vector3d tb = ComputeTranslation(objectPoints, normalized, Rb);
  if (!Finite(Ra, ta) || !Finite(Rb, tb)) {
    st = IppeStatus::kNumericalFailure;
    return false;
  }

  // PoseSolver::sortPosesByReprojError (float errors), then solvePnPGeneric's own comparison
  // of the two: a first when erra < errb, b first when errb < erra, and -- the two swaps
  // cancelling -- a first on a tie.
  PlanarPoseCandidate a, b;
  float erra, errb;
  a.cam_from_marker_R = Ra;
  a.cam_from_marker_t = ta;
  a.reprojection_error = ReprojectionError(objectPoints, normalized, Ra, ta, &erra, &a.in_front);
  b.cam_from_marker_R = Rb;
  b.cam_from_marker_t = tb;
  b.reprojection_error = ReprojectionError(objectPoints, normalized, Rb, tb, &errb, &b.in_front);
  if (errb < erra) {
    (*out)[0] = b;
    (*out)[1] = a;
  } else {
    (*out)[0] = a;
    (*out)[1] = b;
  }
  return true;
}

Pose PlanarTwin(const Pose& cam_from_target) {
  const Eigen::Matrix3d R = cam_from_target.Rotation();
  const Eigen::Vector3d v = cam_from_target.tvec.normalized();
  const Eigen::Vector3d n = R.col(2);
  const Eigen::Vector3d n_twin = 2 * n.dot(v) * v - n;
  return Pose::FromRotation(Eigen::Quaterniond::FromTwoVectors(n, n_twin).toRotationMatrix() * R,
                            cam_from_target.tvec);
}

}  // namespace svms
