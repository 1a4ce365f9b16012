#pragma once
// Checked conversions between Python values and the libraries' Eigen types, for the bindings.
// Every bad argument raises ValueError naming the argument, the bad value and what is allowed
// (e.g. "q: 5 values; puma260 has 6 joints", "q[2]: nan is not a finite number"), so a student's
// mistake never reaches the libraries, and never moves the arm.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace sirupp::python {

namespace py = pybind11;

// A 1-D sequence of `n` finite numbers (list, tuple, ndarray) named `name` in messages.
Eigen::VectorXd VectorArg(const py::handle& value, int n, const std::string& name,
                          const std::string& what_n);
// A 4x4 homogeneous transform: finite, last row 0 0 0 1, rotation orthonormal within 1e-6.
Eigen::Isometry3d PoseArg(const py::handle& value, const std::string& name);

// Copies into new numpy arrays (the caller owns them; nothing refers back to C++).
py::array_t<double> ToArray(const Eigen::VectorXd& values);
py::array_t<double> ToArray(const std::vector<double>& values);
py::array_t<double> ToArray(const Eigen::MatrixXd& values);
py::array_t<double> ToArray(const Eigen::Isometry3d& pose);  // 4x4

}  // namespace sirupp::python
