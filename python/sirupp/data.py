"""The project's text files as numpy arrays: the logger's data files (docs/logging.md, read by
logger/'s reader), the Table II report of `sirupp report` (report_errors.csv, report_response.csv)
and the reference files of `sirupp grade` (its {reference_csv}). Bad files raise ValueError naming
FILE:LINE."""
import csv
import math
import os

import numpy as np


def _number(text, where):
    if text == "":
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise ValueError("%s: '%s' is not a number" % (where, text)) from None
    return value


def _scale(column):
    """SI per unit of a column named ..._deg (rad), ..._mm (m), ..._dps, ..._mmps; else 1."""
    for ending, scale in (("_deg", math.pi / 180), ("_mm", 1e-3), ("_dps", math.pi / 180),
                          ("_mmps", 1e-3), ("_deg_s", math.pi / 180), ("_deg_s2", math.pi / 180),
                          ("_mm_s", 1e-3), ("_mm_s2", 1e-3)):
        if column.endswith(ending):
            return scale
    return 1.0


class DataFile:
    """One data file of sirupp-logger, read by the logger's own reader (logger/data_file.hpp, the
    one `sirupp report` uses): t (time_s), q_set, q_virt, q_real (rows x joints, rad or m; NaN
    where a stream had no sample), move_id, joint_names, label (the movement set), plan_name,
    closed (the logger's "# end" line is there), gains (the "# gains:" lines), notes."""

    def __init__(self, path, table):
        self.path = path
        self.__dict__.update(table)
        self.n = len(self.joint_names)

    def __repr__(self):
        return "<DataFile %s: %d rows, %d joints>" % (os.path.basename(self.path), len(self.t), self.n)


def read_data(path):
    """Reads one data file of sirupp-logger (`logs/NAME-NN-SET.csv`) into a DataFile; ValueError
    naming FILE:LINE for anything that is not the logger's format."""
    from ._sirupp import _read_data_file
    return DataFile(path, _read_data_file(path))


def read_reference(path):
    """Reads a reference file of `sirupp grade` (tick,time_s,q1_deg,v1_deg_s,a1_deg_s2,...):
    {"t", "q", "qd", "qdd"} in SI, one row per tick from 0."""
    with open(path, encoding="utf-8") as f:
        reader = csv.reader(f)
        try:
            head = next(reader)
        except StopIteration:
            raise ValueError("%s:1: empty; expected the header tick,time_s,q1_deg,..." % path) from None
        if len(head) < 5 or (len(head) - 2) % 3 or head[:2] != ["tick", "time_s"]:
            raise ValueError("%s:1: header %s; expected tick,time_s and q,v,a per joint" % (path, ",".join(head)))
        n = (len(head) - 2) // 3
        scales = np.array([_scale(name) for name in head])
        rows = []
        for number, cells in enumerate(reader, 2):
            if len(cells) != len(head):
                raise ValueError("%s:%d: %d values; the header has %d" % (path, number, len(cells), len(head)))
            rows.append([_number(c, "%s:%d" % (path, number)) for c in cells])
    if not rows:
        raise ValueError("%s:2: no rows after the header" % path)
    table = np.array(rows) * scales
    return {"t": table[:, 1], "q": table[:, 2::3][:, :n], "qd": table[:, 3::3][:, :n],
            "qdd": table[:, 4::3][:, :n]}


def _read_csv_table(path):
    with open(path, encoding="utf-8") as f:
        reader = csv.reader(f)
        head = next(reader)
        rows = list(reader)
    out = {}
    for i, name in enumerate(head):
        values = [r[i] if i < len(r) else "" for r in rows]
        try:
            out[name] = np.array([float(v) if v != "" else math.nan for v in values])
        except ValueError:
            out[name] = np.array(values, dtype=object)
    return out


def read_report(folder):
    """The Table II report written by `sirupp report ... --out DIR` (or `sirupp demo`): {"errors":
    report_errors.csv, "response": report_response.csv, "markdown": report.md's text}, each CSV
    as a dict of column -> array (numbers as float, words as str)."""
    errors = os.path.join(folder, "report_errors.csv")
    if not os.path.isfile(errors):
        raise ValueError("%s: no report_errors.csv here (write one with `sirupp report FILES --out %s`)"
                         % (folder, folder))
    result = {"errors": _read_csv_table(errors)}
    response = os.path.join(folder, "report_response.csv")
    if os.path.isfile(response):
        result["response"] = _read_csv_table(response)
    md = os.path.join(folder, "report.md")
    if os.path.isfile(md):
        with open(md, encoding="utf-8") as f:
            result["markdown"] = f.read()
    return result
