// sirupp.read_data's reader (python/sirupp/data.py): the logger's own strict reader of its data
// files (logger/data_file.hpp, the one `sirupp report` uses), its columns handed over in SI.
#include <pybind11/stl.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "logger/data_file.hpp"
#include "python/bindings.hpp"
#include "python/convert.hpp"

namespace sirupp::python {

namespace {

// One stream of every joint as rows x joints, from the file's units (deg, mm) to rad or m.
py::array_t<double> StreamSi(const logger::RunTable& table, logger::Stream stream) {
  const size_t rows = table.rows();
  const size_t joints = table.joints.size();
  py::array_t<double> out({static_cast<py::ssize_t>(rows), static_cast<py::ssize_t>(joints)});
  auto view = out.mutable_unchecked<2>();
  for (size_t j = 0; j < joints; ++j) {
    const std::vector<double>& column = table.position[j][static_cast<size_t>(stream)];
    const double scale = table.joints[j].scale();
    for (size_t r = 0; r < rows; ++r) {
      view(static_cast<py::ssize_t>(r), static_cast<py::ssize_t>(j)) = column[r] / scale;
    }
  }
  return out;
}

py::dict ReadDataFile(const std::string& path) {
  logger::RunTable table;
  try {
    py::gil_scoped_release release;
    table = logger::ReadDataFile(path);
  } catch (const core::ConfigError& error) {
    throw py::value_error(error.what());  // "FILE:LINE: problem"
  }
  py::dict d;
  d["t"] = ToArray(table.time_s);
  d["q_set"] = StreamSi(table, logger::Stream::kSetpoint);
  d["q_virt"] = StreamSi(table, logger::Stream::kVirtual);
  d["q_real"] = StreamSi(table, logger::Stream::kReal);
  d["move_id"] =
      py::array_t<int64_t>(static_cast<py::ssize_t>(table.move_id.size()), table.move_id.data());
  py::list names;
  for (const logger::JointInfo& joint : table.joints) names.append(joint.name);
  d["joint_names"] = names;
  d["label"] = table.label;
  d["plan_name"] = table.plan_name;
  d["closed"] = table.closed;
  d["gains"] = table.gains;
  d["notes"] = table.notes;
  d["realtime_factor"] = table.realtime_factor;
  return d;
}

}  // namespace

void BindData(py::module_& m) {
  m.def("_read_data_file", &ReadDataFile, py::arg("path"),
        "a sirupp-logger data file through logger/'s reader (use sirupp.read_data)");
}

}  // namespace sirupp::python
