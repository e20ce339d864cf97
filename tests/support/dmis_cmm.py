"""A simulated CMM that runs the DMIS programs cmmsampling writes and fills their OUTPUT.

The part lies on the table misplaced by a rigid motion M (its CAD coordinates -> the machine's)
with a smooth form error f along each face's normal; the operator's frame is the machine's. The
statements it runs (DMIS 5.2 as read here, written independently of the writer):
FEAT/POINT, FEAT/PLANE and FEAT/CYLNDR nominals in the current frame; MEAS/POINT with its PTMEAS
(the probe comes along the nominal vector and touches the part where the nominal point's foot on
the CAD face, plus the form error along its normal, lies on the misplaced part); CONST/PLANE BF
(least squares plane through the actual points, its normal the nominal's side) and CONST/CYLNDR
BF (least squares cylinder: the sum of squared radial distances, started from the nominal, its
axis the nominal's side); DATDEF; DATSET with ZDIR/XDIR/YDIR and XORIG/YORIG/ZORIG (a direction
word makes the datum's normal or axis that axis, the next one's made square to the axes before
it; an origin word puts that coordinate's zero on the datum's plane, or on its cylinder's axis);
TRANS/XORIG.. (the origin moves to that point of the current frame) and
ROTAT/<axis>,angle (the frame turns about its current axis, right-handed, degrees); OUTPUT/FA of
a point: its actual contact point and the face's normal there in the current frame. Everything
else is read over."""
import re

import numpy as np

from cmmsampling.formats.dmis import dmis_statements
from cmmsampling.inspection.closest import FaceCloser

_ASSIGNED = re.compile(r"(F|D|T|S|DID)\(([^()]*)\)=([A-Z]+)/(.*)\Z")
_AXES = {"XAXIS": 0, "YAXIS": 1, "ZAXIS": 2}


def rotation(axis, degrees):
    """(3, 3) right-handed rotation about coordinate axis 0, 1 or 2."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    i, j = [k for k in range(3) if k != axis]
    matrix = np.eye(3)
    matrix[[i, i, j, j], [i, j, i, j]] = c, -s, s, c
    return matrix if axis != 1 else matrix.T   # about Y the pair (x, z) turns the other way


class DmisCMM:
    """Runs a program against a part: faces {name: Part.Face} (a point labelled '<face>_P<k>'
    touches that face, any other the only face), misplacement (4, 4) CAD -> machine, form: a
    function of CAD points (M, 3) -> (M,) mm along the normal."""

    def __init__(self, faces, misplacement, form):
        self.closers = {name: FaceCloser(face, bounded=False) for name, face in faces.items()}
        self.misplacement, self.form = np.asarray(misplacement, dtype=float), form
        self.frame = np.eye(4)
        self.nominal, self.actual, self.datums, self.lines = {}, {}, {}, []

    def run(self, text, name="simulated"):
        """The output file's text of the program text."""
        self.lines = [f"DMISMN/'{name}',05.2", "UNITS/MM,ANGDEC"]
        measuring = None
        for _, statement in dmis_statements(text)[0]:
            statement = statement.replace(" ", "")
            if statement.startswith("MEAS/"):
                measuring = statement.split("F(")[1].split(")")[0]
            elif statement.startswith("PTMEAS/CART,"):
                self.actual[measuring] = self.touch(measuring)
            elif statement.startswith("ENDMES"):
                measuring = None
            else:
                self.execute(statement)
        return "\n".join(self.lines + ["ENDFIL"]) + "\n"

    def execute(self, statement):
        """One statement that is no MEAS block's."""
        assigned = _ASSIGNED.match(statement)
        if assigned:
            kind, label, word, rest = assigned.groups()
            fields = rest.split(",")
            if kind == "F" and word == "FEAT" and fields[0] in ("POINT", "PLANE"):
                self.nominal[label] = np.array([float(v) for v in fields[2:8]])
            elif kind == "F" and word == "FEAT" and fields[0] == "CYLNDR":
                self.nominal[label] = np.array([float(v) for v in fields[3:10]])
            elif kind == "D" and word == "DATSET":
                self.frame = self.datum_set(fields)
            elif kind == "D" and word == "TRANS":
                self.frame = self.frame @ _moved(np.array([float(v) for v in fields[1::2]]))
            elif kind == "D" and word == "ROTAT":
                turn = np.eye(4)
                turn[:3, :3] = rotation(_AXES[fields[0]], float(fields[1]))
                self.frame = self.frame @ turn
            return
        if statement.startswith(("CONST/PLANE,", "CONST/CYLNDR,")):
            fields = statement.split(",")
            label = fields[1][2:-1]
            fit = self.plane if statement.startswith("CONST/PLANE,") else self.cylinder
            self.actual[label] = fit(label, [field[3:-1] for field in fields[3:]])
        elif statement.startswith("DATDEF/FA("):
            feature, datum = re.match(r"DATDEF/FA\(([^()]*)\),DAT\(([^()]*)\)", statement).groups()
            self.datums[datum] = self.actual[feature]
        elif statement.startswith("OUTPUT/FA(") and ",TA(" not in statement:
            label = statement[len("OUTPUT/FA("):-1]
            self.output(label)

    def touch(self, label):
        """(contact (3,), normal (3,)) in machine coordinates where the probe touches the
        nominal point of label (given in the current frame)."""
        nominal = self.nominal[label]
        machine = self.frame[:3, :3] @ nominal[:3] + self.frame[:3, 3]
        back = np.linalg.inv(self.misplacement)
        cad = back[:3, :3] @ machine + back[:3, 3]
        closer = self.closers[label.rsplit("_P", 1)[0]] if len(self.closers) > 1 else next(iter(self.closers.values()))
        foot, normal = (values[0] for values in closer(cad[None])[:2])
        touched = foot + self.form(foot[None])[0] * normal
        return (self.misplacement[:3, :3] @ touched + self.misplacement[:3, 3],
                self.misplacement[:3, :3] @ normal)

    def plane(self, label, members):
        """(centre (3,), unit normal (3,)) machine: the least-squares plane through the actual
        points of members, its normal on the side of the nominal plane's (label)."""
        points = np.array([self.actual[member][0] for member in members])
        centre = points.mean(axis=0)
        normal = np.linalg.svd(points - centre)[2][-1]
        wanted = self.frame[:3, :3] @ self.nominal[label][3:]
        return centre, normal if normal @ wanted > 0 else -normal

    def cylinder(self, label, members):
        """("cylinder", point on the axis (3,), unit axis (3,)) machine: the least-squares
        cylinder through the actual points of members, started from the nominal (label)."""
        from scipy.optimize import least_squares

        points = np.array([self.actual[member][0] for member in members])
        nominal = self.nominal[label]
        start_point = self.frame[:3, :3] @ nominal[:3] + self.frame[:3, 3]
        start_axis = self.frame[:3, :3] @ nominal[3:6]

        def axis_of(angles):
            return np.array([np.sin(angles[0]) * np.cos(angles[1]), np.sin(angles[0]) * np.sin(angles[1]),
                             np.cos(angles[0])])

        def radial(values):
            axis = axis_of(values[3:5])
            offset = points - values[:3]
            return np.linalg.norm(offset - np.outer(offset @ axis, axis), axis=1) - values[5]

        angles = [np.arccos(np.clip(start_axis[2], -1, 1)), np.arctan2(start_axis[1], start_axis[0])]
        found = least_squares(radial, [*start_point, *angles, nominal[6] / 2], xtol=1e-14, ftol=1e-14).x
        axis = axis_of(found[3:5])
        return "cylinder", found[:3], axis if axis @ start_axis > 0 else -axis

    def datum_set(self, fields):
        """The frame (4, 4, current -> machine) DATSET's fields set from the datums' planes."""
        axes, origins, current = {}, [], None
        for field in fields:
            if field.startswith("DAT("):
                current = self.datums[field[4:-1]]
            elif field.endswith("DIR"):
                axis = "XYZ".index(field[0])
                given = current[-1]
                direction = given - sum((given @ made) * made for made in axes.values())
                axes[axis] = direction / np.linalg.norm(direction)
            elif field.endswith("ORIG"):
                origins.append(("XYZ".index(field[0]), current))
        for axis in range(3):
            if len(axes) == 1 and axis not in axes:
                given = self.frame[:3, axis] - sum((self.frame[:3, axis] @ made) * made for made in axes.values())
                axes[axis] = given / np.linalg.norm(given)
        third = ({0, 1, 2} - set(axes)).pop()
        u, v = {2: (0, 1), 0: (1, 2), 1: (2, 0)}[third]
        axes[third] = np.cross(axes[u], axes[v])
        rotation_matrix = np.column_stack([axes[k] for k in range(3)])
        if np.linalg.det(rotation_matrix) < 0:
            raise AssertionError("DATSET set a left-handed frame")
        rows = np.array([rotation_matrix[:, axis] if isinstance(datum[0], str) else datum[1]
                         for axis, datum in origins])
        values = np.array([row @ datum[-2] for row, (_, datum) in zip(rows, origins)])
        origin = np.linalg.lstsq(rows, values, rcond=None)[0]
        frame = np.eye(4)
        frame[:3, :3], frame[:3, 3] = rotation_matrix, origin
        return frame

    def output(self, label):
        """FA(label)=FEAT/POINT,CART,x,y,z,i,j,k of a measured point, in the current frame."""
        if label not in self.actual or len(self.actual[label][0]) != 3 or label.startswith("DAT_"):
            return
        contact, normal = self.actual[label]
        back = np.linalg.inv(self.frame)
        point = back[:3, :3] @ contact + back[:3, 3]
        vector = back[:3, :3] @ normal
        numbers = ",".join(f"{value:.7f}" for value in point) + "," + ",".join(f"{value:.9f}" for value in vector)
        self.lines.append(f"FA({label})=FEAT/POINT,CART,{numbers}")


def _moved(origin):
    """(4, 4): a frame whose origin is at origin (3,) of the current one."""
    frame = np.eye(4)
    frame[:3, 3] = origin
    return frame
