"""A DMIS program's datums and tolerances: the part's frame set from its datum features, and the
surface profile of each toleranced face stated for the CMM's own report.

A plan made with datums (``plan(..., datums=[...])``) states them in its points' metadata
(``datums``: {label: face}); its datum points come first. The program then (DMIS 5.2 forms):

- measures each datum face's points (FEAT/POINT, MEAS/POINT, PTMEAS), in the frame the
  operator set (the part roughly on the CAD model's coordinates, within the search distance);
- for a planar datum face constructs the plane through them, least squares
  (``F(DAT_A)=FEAT/PLANE,CART,x,y,z,i,j,k``, ``CONST/PLANE,F(DAT_A),BF,FA(..),...``), for a
  cylindrical one the cylinder (``F(DAT_B)=FEAT/CYLNDR,INNER,CART,x,y,z,i,j,k,d,l`` as NIST's
  program writes a bore, ``CONST/CYLNDR,F(DAT_B),BF,...``), and makes it the datum
  (``DATDEF/FA(DAT_A),DAT(A)``); a datum face that is neither has no DMIS feature here: a
  comment says so and its points stay for cmmsampling.inspect;
- sets the datum reference frame where the datums are planes and cylinders (e.g.
  ``D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XDIR,XORIG,DAT(C),YORIG``: A's normal is +Z and its
  plane Z = 0, B's normal projected square to it +X and its plane X = 0, C's plane Y = 0; a bore
  B square to A sets XORIG,YORIG on its axis and a side C then XDIR: :func:`datum_frame`), then
  moves to the CAD model's frame as
  the nominal datums place it in that frame (``D(CAD)=TRANS/...``, ``ROTAT/...``), so that every
  nominal after it is the CAD model's and every actual is reported in it;
- reports the datum points (``OUTPUT/FA(..)``) once that frame is set, so all the points of the
  output file are in one frame;
- states each toleranced face's surface profile (``T(PROF_Face3)=TOL/PROFS,lo,up,DAT(A),...``),
  and after its points groups them (``F(Face3)=FEAT/PATERN,F(..),...``, ``CONST/PATERN,F(Face3),
  BUILD,FA(..),...``) and reports the profile on that group (``OUTPUT/FA(Face3),TA(PROF_Face3)``).

What DMIS cannot state is said in comments: the CMM evaluates the profile by its own method;
cmmsampling.inspect judges the same points to ISO 1101 on tangent datums (ISO 5459) with the
expanded uncertainty and ISO 14253-1's decision.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .text import COORDINATE_DECIMALS, VECTOR_DECIMALS, fixed

ANGLE_DECIMALS = 4
# A datum face's points are taken as on one plane when their normals agree to this (1 - cos)
# and the points lie this close (mm) to the plane through their centroid; as on one cylinder when
# their normals are square to one axis to this (|cos|) and the points lie this close (mm) to it.
PLANE_NORMAL_AGREEMENT = 1e-9
PLANE_DISTANCE_MM = 1e-6
CYLINDER_AXIS_AGREEMENT = 1e-9
CYLINDER_DISTANCE_MM = 1e-6
# A direction or an origin the datum sets is stated for a frame axis it lies along to this (1 - |cos|).
AXIS_AGREEMENT = 1e-6
DRF_LABEL, CAD_LABEL = "DRF", "CAD"


@dataclass
class Cylinder:
    """A datum cylinder: point (3,) mm on its axis (mid-way along the points), axis (3,) unit,
    diameter and length (the points' extent along the axis) mm, inner (a bore: the material
    outside it)."""

    point: np.ndarray
    axis: np.ndarray
    diameter: float
    length: float
    inner: bool


@dataclass
class DatumGroup:
    """One datum of a program: label ('A'), faces (('Face3',); a bore's halves ('Face43',
    'Face44')), rows (its points' indices in the point set), and its plane (centre (3,) mm, unit normal (3,) out of the material) where its
    nominal points lie on one, or its Cylinder where they lie on one, else both None."""

    label: str
    faces: tuple
    rows: np.ndarray
    plane: tuple[np.ndarray, np.ndarray] | None
    cylinder: Cylinder | None = None

    @property
    def feature(self) -> str:
        """The datum feature's DMIS label, e.g. 'DAT_A'."""
        return f"DAT_{self.label}"

    @property
    def direction(self) -> np.ndarray | None:
        """(3,) unit: the direction the datum gives a frame (a plane's normal, a cylinder's axis)."""
        if self.plane is not None:
            return self.plane[1]
        return None if self.cylinder is None else self.cylinder.axis


def datum_groups(point_set) -> list[DatumGroup]:
    """The DatumGroups of a point set whose metadata states ``datums`` ({label: face, or a list
    of faces for a datum of several}, primary first) and whose ``faces`` name each point's face;
    [] for one without. A datum of several faces is one DMIS feature where their points lie on
    one plane or one cylinder (coplanar faces, a bore's halves)."""
    stated = point_set.datum_faces()
    return [DatumGroup(label, stated[label], rows, *datum_feature(point_set.points[rows], point_set.normals[rows]))
            for label, rows in point_set.datum_rows().items()]


def datum_feature(points: np.ndarray, normals: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray] | None,
                                                                    Cylinder | None]:
    """(plane, None) where a datum's nominal points (M, 3) mm with their normals (M, 3) lie on one
    plane ((centre (3,), unit normal (3,))), (None, Cylinder) where on one cylinder, else (None,
    None): a datum that has no DMIS feature here."""
    plane = _plane(points, normals)
    return plane, None if plane is not None else _cylinder(points, normals)


def _plane(points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(centroid (3,), unit normal (3,)) of points (M, 3) mm on one plane with one normal
    (normals (M, 3)), else None."""
    normal = normals.mean(axis=0)
    normal /= np.linalg.norm(normal)
    centre = points.mean(axis=0)
    if (1.0 - normals @ normal).max() > PLANE_NORMAL_AGREEMENT:
        return None
    if np.abs((points - centre) @ normal).max() > PLANE_DISTANCE_MM:
        return None
    return centre, normal


def _cylinder(points: np.ndarray, normals: np.ndarray) -> Cylinder | None:
    """The Cylinder points (M, 3) mm with normals (M, 3) out of the material lie on (each point
    p = c + r n with c on the axis: r > 0 a shaft, r < 0 a bore), else None (fewer than 6 points,
    which a CMM fits no least-squares cylinder through, or no cylinder)."""
    if len(points) < 6:
        return None
    axis = np.linalg.svd(normals)[2][-1]
    if np.abs(normals @ axis).max() > CYLINDER_AXIS_AGREEMENT:
        return None
    across = np.eye(3) - np.outer(axis, axis)
    flat = points @ across
    rows = np.hstack([np.tile(np.eye(3), (len(points), 1)), normals.reshape(-1, 1)])
    solved = np.linalg.lstsq(rows, flat.reshape(-1), rcond=None)[0]
    centre, radius = solved[:3], solved[3]
    if np.abs(flat - centre - radius * normals).max() > CYLINDER_DISTANCE_MM or abs(radius) < CYLINDER_DISTANCE_MM:
        return None
    heights = points @ axis
    point = centre + 0.5 * (heights.min() + heights.max()) * axis
    return Cylinder(point, axis, 2.0 * abs(float(radius)), float(np.ptp(heights)), bool(radius < 0))


@dataclass
class DatumFrame:
    """The frame a program's datums set: frame (4, 4), its axes (rotation columns X, Y, Z) and
    origin in the coordinates the datums are given in, and words: DATSET's minor words of each
    datum in precedence order (e.g. ['ZDIR', 'ZORIG'], ['XORIG', 'YORIG'], ['XDIR'])."""

    frame: np.ndarray
    words: list


def datum_frame(groups: list[DatumGroup]) -> DatumFrame:
    """The DatumFrame of planar and cylindrical datums in precedence order: the first direction
    (a plane's normal, a cylinder's axis) is +Z (ZDIR), the next one square to it made +X (XDIR),
    else the given frame's X or Y axis made square to Z; Y = Z x X. Each datum then sets the
    origin's coordinates not set before it that it can: a plane the one along its normal (the
    origin on the plane), a cylinder the two square to its axis (the origin on the axis); the
    others stay where the given frame's origin is nearest. A datum that adds nothing DATSET can
    state (a second bore parallel to the first) has no words: what it would fix stays as given.
    ValueError for a direction or origin along no frame axis."""
    directions = [_direction(group) for group in groups]
    z, x = directions[0], None
    words: list[list[str]] = [["ZDIR"]] + [[] for _ in groups[1:]]
    for direction, said in zip(directions[1:], words[1:]):
        across = direction - (direction @ z) * z
        if x is None and np.linalg.norm(across) > AXIS_AGREEMENT:
            x = across / np.linalg.norm(across)
            said.append("XDIR")
    if x is None:
        across = np.eye(3)[0] if abs(z[0]) < 0.9 else np.eye(3)[1]
        x = across - (across @ z) * z
        x /= np.linalg.norm(x)
    axes = {"X": x, "Y": np.cross(z, x), "Z": z}
    rows, values = [], []
    for group, said in zip(groups, words):
        for name in _origin_axes(group, axes, {word[0] for words_of in words for word in words_of
                                               if word.endswith("ORIG")}):
            said.append(f"{name}ORIG")
            row = group.plane[1] if group.plane is not None else axes[name]
            rows.append(row)
            values.append(row @ _anchor(group))
    frame = np.eye(4)
    frame[:3, :3] = np.column_stack([axes["X"], axes["Y"], axes["Z"]])
    frame[:3, 3] = np.linalg.lstsq(np.array(rows), np.array(values), rcond=None)[0]
    return DatumFrame(frame, words)


def _direction(group: DatumGroup) -> np.ndarray:
    """(3,) unit: the datum's direction; ValueError for a datum that is no plane or cylinder."""
    direction = group.direction
    if direction is None:
        raise ValueError(f"datum {group.label} is no plane or cylinder")
    return direction


def _anchor(group: DatumGroup) -> np.ndarray:
    """(3,) mm: a point the datum passes through (a plane's centre, a point on a cylinder's axis)."""
    if group.plane is not None:
        return group.plane[0]
    if group.cylinder is not None:
        return group.cylinder.point
    raise ValueError(f"datum {group.label} is no plane or cylinder")


def _origin_axes(group: DatumGroup, axes: dict, taken: set) -> list[str]:
    """The frame axes ('X', 'Y', 'Z') whose origin coordinate the datum sets that no datum before
    it set (taken): a plane's normal's axis, a cylinder's two axes square to its own; ValueError
    where the plane's normal or the cylinder's axis lies along no frame axis."""
    direction = _direction(group)
    along = [name for name, axis in axes.items() if abs(abs(direction @ axis) - 1.0) < AXIS_AGREEMENT]
    if not along:
        kind = "plane's normal" if group.plane is not None else "cylinder's axis"
        raise ValueError(f"datum {group.label}'s {kind} lies along no axis of the frame the datums set")
    names = along if group.plane is not None else [name for name in "XYZ" if name != along[0]]
    return [name for name in names if name not in taken]


def yaw_pitch_roll(rotation: np.ndarray) -> tuple[float, float, float]:
    """Degrees (a, b, c) of a (3, 3) rotation R = Rz(a) Ry(b) Rx(c); at b = +-90 deg (where only
    a -+ c is fixed) c = 0."""
    pitch = np.degrees(np.arcsin(np.clip(-rotation[2, 0], -1.0, 1.0)))
    if np.hypot(rotation[0, 0], rotation[1, 0]) < 1e-12:
        return float(np.degrees(np.arctan2(-rotation[0, 1], rotation[1, 1]))), float(pitch), 0.0
    yaw = np.degrees(np.arctan2(rotation[1, 0], rotation[0, 0]))
    roll = np.degrees(np.arctan2(rotation[2, 1], rotation[2, 2]))
    return float(yaw), float(pitch), float(roll)


def placement_statements(label: str, frame: np.ndarray, statement) -> list[str]:
    """D(label)=TRANS/XORIG,x,YORIG,y,ZORIG,z then D(label)=ROTAT/ZAXIS,a, ROTAT/YAXIS,b,
    ROTAT/XAXIS,c (rotations of 0 left out): the frame (4, 4) (its axes and origin in the current
    coordinates) made current; statement: dmis.dmis_statement."""
    origin = fixed(frame[:3, 3], COORDINATE_DECIMALS).tolist()
    lines = statement([f"D({label})=TRANS/XORIG", origin[0], "YORIG", origin[1], "ZORIG", origin[2]])
    for axis, angle in zip(("ZAXIS", "YAXIS", "XAXIS"), yaw_pitch_roll(frame[:3, :3])):
        text = fixed(angle, ANGLE_DECIMALS).item()
        if float(text) != 0.0:
            lines.append(f"D({label})=ROTAT/{axis},{text}")
    return lines


def datum_feature_lines(group: DatumGroup, labels: list[str], statement) -> list[str]:
    """The datum's DMIS feature (a plane or a cylinder, least squares through its points) and
    DATDEF, else a comment."""
    members = [f"FA({labels[k]})" for k in group.rows]
    cylinder = group.cylinder
    if group.plane is not None:
        centre, normal = group.plane
        nominal = fixed(centre, COORDINATE_DECIMALS).tolist() + fixed(normal, VECTOR_DECIMALS).tolist()
        feature = statement([f"F({group.feature})=FEAT/PLANE", "CART", *nominal[:3]], nominal[3:])
        constructed = statement(["CONST/PLANE", f"F({group.feature})", "BF", *members])
    elif cylinder is not None:
        sizes = fixed(np.array([cylinder.diameter, cylinder.length]), COORDINATE_DECIMALS).tolist()
        feature = statement([f"F({group.feature})=FEAT/CYLNDR", "INNER" if cylinder.inner else "OUTER", "CART",
                             *fixed(cylinder.point, COORDINATE_DECIMALS).tolist()],
                            fixed(cylinder.axis, VECTOR_DECIMALS).tolist() + sizes)
        constructed = statement(["CONST/CYLNDR", f"F({group.feature})", "BF", *members])
    else:
        return [f"$$ datum {group.label} ({' '.join(group.faces)}) is no plane or cylinder: no DMIS datum feature is written",
                "$$+ for it; its points are reported for cmmsampling.inspect, which associates it"]
    return feature + constructed + [f"DATDEF/FA({group.feature}),DAT({group.label})"]


def frame_lines(groups: list[DatumGroup], statement) -> list[str]:
    """DATSET of the planar and cylindrical datums and the move to the CAD frame; comments where
    a datum is neither or the datums cannot set a frame."""
    if not groups:
        return []
    if any(group.direction is None for group in groups):
        return ["$$ the datums are not all planes or cylinders: the part's frame stays as the operator set it;",
                "$$+ cmmsampling.inspect aligns the reported points on the datums"]
    try:
        found = datum_frame(groups)
    except ValueError as exc:
        return [f"$$ the datums set no frame here ({exc}): the part's frame stays as the operator set it"]
    fields = [field for group, words in zip(groups, found.words) if words
              for field in [f"DAT({group.label})", *words]]
    rotation, origin = found.frame[:3, :3], found.frame[:3, 3]
    back = np.eye(4)
    back[:3, :3] = rotation.T
    back[:3, 3] = -rotation.T @ origin
    unstated = [f"datum {group.label} ({' '.join(group.faces)}) sets nothing DATSET can state after the datums "
                "before it: what it would fix (the turn about a bore's axis) stays as the operator set it; "
                "cmmsampling.inspect aligns the reported points on every datum"
                for group, words in zip(groups, found.words) if not words]
    return ([f"$$ {line}" for line in unstated] + ["$$ the frame the datums set, then the CAD model's frame in it"]
            + statement([f"D({DRF_LABEL})=DATSET/{fields[0]}", *fields[1:]])
            + placement_statements(CAD_LABEL, back, statement))


def tolerance_label(face: str) -> str:
    """The profile tolerance's DMIS label of a face, e.g. 'PROF_Face3'."""
    return f"PROF_{face}"


# What DMIS cannot state of the verdict, said before the profile tolerances.
VERDICT_COMMENT = ["$$ the CMM evaluates these profiles its own way; cmmsampling.inspect judges",
                   "$$+ the same points to ISO 1101 on tangent datums (ISO 5459) with the",
                   "$$+ expanded uncertainty U and ISO 14253-1's decision, which DMIS cannot state"]


def tolerance_lines(faces: list[str], tolerance: float, groups: list[DatumGroup], statement) -> list[str]:
    """T(PROF_<face>)=TOL/PROFS,-t/2,+t/2[,DAT(A),...] for each toleranced face (tolerance t mm),
    after VERDICT_COMMENT."""
    limits = fixed(np.array([-0.5 * tolerance, 0.5 * tolerance]), COORDINATE_DECIMALS).tolist()
    datums = [f"DAT({group.label})" for group in groups if group.direction is not None]
    return VERDICT_COMMENT + [line for face in faces
                              for line in statement([f"T({tolerance_label(face)})=TOL/PROFS", *limits, *datums])]


def profile_lines(face: str, labels: list[str], statement) -> list[str]:
    """The face's points grouped and its profile reported: FEAT/PATERN, CONST/PATERN BUILD,
    OUTPUT with its TA."""
    return (statement([f"F({face})=FEAT/PATERN", *[f"F({label})" for label in labels]])
            + statement(["CONST/PATERN", f"F({face})", "BUILD", *[f"FA({label})" for label in labels]])
            + [f"OUTPUT/FA({face}),TA({tolerance_label(face)})"])
