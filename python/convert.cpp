#include "python/convert.hpp"

#include <cmath>

#include "core/errors.hpp"

namespace sirupp::python {

namespace {

// Any array-like as a C-contiguous float64 array; ValueError naming `name` when it is not numbers.
py::array_t<double, py::array::c_style | py::array::forcecast> NumbersOf(const py::handle& value,
                                                                         const std::string& name) {
  if (value.is_none()) throw py::value_error(name + ": None; expected numbers");
  if (py::isinstance<py::str>(value) || py::isinstance<py::bytes>(value)) {
    throw py::value_error(name + ": a string; expected numbers");
  }
  auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!array) {
    throw py::value_error(name + ": " + std::string(py::str(py::repr(value))).substr(0, 80) +
                          " is not an array of numbers");
  }
  return array;
}

void CheckFinite(double v, const std::string& where) {
  if (!std::isfinite(v)) {
    throw py::value_error(where + ": " + core::FormatNumber(v) + " is not a finite number");
  }
}

}  // namespace

Eigen::VectorXd VectorArg(const py::handle& value, int n, const std::string& name,
                          const std::string& what_n) {
  auto array = NumbersOf(value, name);
  if (array.ndim() != 1) {
    throw py::value_error(name + ": an array of " + std::to_string(array.ndim()) +
                          " dimensions; expected " + std::to_string(n) + " values (" + what_n +
                          ")");
  }
  if (array.shape(0) != n) {
    throw py::value_error(name + ": " + std::to_string(array.shape(0)) + " values; expected " +
                          std::to_string(n) + " (" + what_n + ")");
  }
  Eigen::VectorXd out(n);
  const double* data = array.data();
  for (int i = 0; i < n; ++i) {
    CheckFinite(data[i], name + "[" + std::to_string(i) + "]");
    out[i] = data[i];
  }
  return out;
}

Eigen::Isometry3d PoseArg(const py::handle& value, const std::string& name) {
  auto array = NumbersOf(value, name);
  if (array.ndim() != 2 || array.shape(0) != 4 || array.shape(1) != 4) {
    std::string shape;
    for (py::ssize_t d = 0; d < array.ndim(); ++d) {
      shape += (d ? "x" : "") + std::to_string(array.shape(d));
    }
    throw py::value_error(name + ": shape " + (shape.empty() ? "()" : shape) +
                          "; expected a 4x4 homogeneous transform (e.g. from fkine)");
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      m(r, c) = array.at(r, c);
      CheckFinite(m(r, c), name + "[" + std::to_string(r) + "][" + std::to_string(c) + "]");
    }
  }
  if (m(3, 0) != 0 || m(3, 1) != 0 || m(3, 2) != 0 || m(3, 3) != 1) {
    throw py::value_error(name + ": last row " + core::FormatApprox(m(3, 0)) + " " +
                          core::FormatApprox(m(3, 1)) + " " + core::FormatApprox(m(3, 2)) + " " +
                          core::FormatApprox(m(3, 3)) + "; expected 0 0 0 1");
  }
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double off = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (off > 1e-6 || r.determinant() < 0) {
    throw py::value_error(name + ": the rotation part is not a rotation (R^T R differs from I by " +
                          core::FormatApprox(off) + ", det " + core::FormatApprox(r.determinant()) +
                          "); expected an orthonormal 3x3 with det +1");
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = r;
  pose.translation() = m.topRightCorner<3, 1>();
  return pose;
}

py::array_t<double> ToArray(const Eigen::VectorXd& values) {
  py::array_t<double> out(values.size());
  std::copy(values.data(), values.data() + values.size(), out.mutable_data());
  return out;
}

py::array_t<double> ToArray(const std::vector<double>& values) {
  py::array_t<double> out(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}

py::array_t<double> ToArray(const Eigen::MatrixXd& values) {
  py::array_t<double> out({values.rows(), values.cols()});
  auto view = out.mutable_unchecked<2>();
  for (Eigen::Index r = 0; r < values.rows(); ++r) {
    for (Eigen::Index c = 0; c < values.cols(); ++c) view(r, c) = values(r, c);
  }
  return out;
}

py::array_t<double> ToArray(const Eigen::Isometry3d& pose) {
  return ToArray(Eigen::MatrixXd(pose.matrix()));
}

}  // namespace sirupp::python
