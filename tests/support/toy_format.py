"""A toy point-file format, added the way a new format is: one module with its reader, its
writer and one record. tests/formats/test_format_records.py and the GUI tests register it and see it
offered everywhere."""
import numpy as np

import cmmsampling
from cmmsampling.formats.pointset import PointSet


def write(point_set, facts, options):
    """One point per line: 'label x y z i j k', mm, after a first line 'TOY <count>'."""
    rows = [" ".join([label] + [f"{value:.6f}" for value in (*point, *normal)])
            for label, point, normal in zip(point_set.labels, point_set.points, point_set.normals)]
    return "\n".join([f"TOY {len(rows)}"] + rows) + "\n"


def read(text, path="<text>"):
    """The PointSet of a toy file; ValueError naming the path and the line otherwise."""
    lines = text.splitlines()
    if not lines or not lines[0].startswith("TOY "):
        raise ValueError(f"{path}, line 1: expected 'TOY <count>'")
    rows = [line.split() for line in lines[1:] if line.strip()]
    for number, row in enumerate(rows, start=2):
        if len(row) != 7:
            raise ValueError(f"{path}, line {number}: expected a label and six numbers, got {len(row)} fields")
    values = np.array([[float(v) for v in row[1:]] for row in rows])
    return PointSet([row[0] for row in rows], values[:, :3], values[:, 3:])


TOY_FORMAT = cmmsampling.FileFormat("toy", "toy points", "toy point file (label x y z i j k)", (".toy",),
                                    "ascii", write, read)
