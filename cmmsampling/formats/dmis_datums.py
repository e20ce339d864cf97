"""A DMIS program's datums and tolerances: the part's frame set from its datum features, and the
surface profile of each toleranced face stated for the CMM's own report.

A plan made with datums (``plan(..., datums=[...])``) states them in its points' metadata
(``datums``: {label: face}); its datum points come first. The program then (DMIS 5.2 forms):

- measures each datum face's points (FEAT/POINT, MEAS/POINT, PTMEAS), in the frame the
  operator set (the part roughly on the CAD model's coordinates, within the search distance);
- for a planar datum face constructs the plane through them, least squares
  (``F(DAT_A)=FEAT/PLANE,CART,x,y,z,i,j,k``, ``CONST/PLANE,F(DAT_A),BF,FA(..),...``) and makes it
  the datum (``DATDEF/FA(DAT_A),DAT(A)``); a datum face that is no plane has no DMIS feature
  here: a comment says so and its points stay for cmmsampling.inspect;
- sets the datum reference frame where the datums are planes (``D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,
  DAT(B),XDIR,XORIG,DAT(C),YORIG``: A's normal is +Z and its plane Z = 0, B's normal projected
  square to it +X and its plane X = 0, C's plane Y = 0), then moves to the CAD model's frame as
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
# and the points lie this close (mm) to the plane through their centroid.
PLANE_NORMAL_AGREEMENT = 1e-9
PLANE_DISTANCE_MM = 1e-6
# DATSET's minor words for the primary, secondary and tertiary planar datum: the axis each
# datum's normal gives (None: none) and the origin it sets.
DATSET_WORDS = (("ZDIR", "ZORIG"), ("XDIR", "XORIG"), (None, "YORIG"))
DRF_LABEL, CAD_LABEL = "DRF", "CAD"


@dataclass
class DatumGroup:
    """One datum of a program: label ('A'), face ('Face3'), rows (its points' indices in the
    point set), and its plane (centre (3,) mm, unit normal (3,) out of the material) where its
    nominal points lie on one, else None."""

    label: str
    face: str
    rows: np.ndarray
    plane: tuple[np.ndarray, np.ndarray] | None

    @property
    def feature(self) -> str:
        """The datum feature's DMIS label, e.g. 'DAT_A'."""
        return f"DAT_{self.label}"


def datum_groups(point_set) -> list[DatumGroup]:
    """The DatumGroups of a point set whose metadata states ``datums`` ({label: face}, primary
    first) and whose ``faces`` name each point's face; [] for one without."""
    stated = point_set.metadata.get("datums") or {}
    if not stated or point_set.faces is None:
        return []
    faces = np.array(point_set.faces, dtype=object)
    groups = []
    for label, face in stated.items():
        rows = np.flatnonzero(faces == face)
        if rows.size:
            groups.append(DatumGroup(label, face, rows, _plane(point_set.points[rows], point_set.normals[rows])))
    return groups


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


def datum_frame(planes: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """(4, 4): the datum reference frame of 1 to 3 planes (centre (3,), unit normal (3,)) in
    precedence order, in the coordinates they are given in: rotation columns X, Y, Z and the
    origin, as DATSET_WORDS sets them (A's normal Z; B's normal made square to Z, X, else the
    given frame's X or Y axis made square to Z; Y = Z x X; the origin on each plane, nearest the
    given frame's origin where fewer than 3 planes fix it). ValueError for planes that cannot
    set it (B parallel to A; C square to Y)."""
    normals = np.array([normal for _, normal in planes])
    offsets = np.array([normal @ centre for centre, normal in planes])
    z = normals[0]
    across = normals[1] if len(planes) > 1 else (np.eye(3)[0] if abs(z[0]) < 0.9 else np.eye(3)[1])
    x = across - (across @ z) * z
    if np.linalg.norm(x) < 1e-6:
        raise ValueError("datum B is parallel to datum A: it sets no direction")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    if len(planes) > 2 and abs(normals[2] @ y) < 1e-6:
        raise ValueError("datum C is square to the Y axis datums A and B set: it sets no origin")
    origin = np.linalg.lstsq(normals, offsets, rcond=None)[0]
    frame = np.eye(4)
    frame[:3, :3] = np.column_stack([x, y, z])
    frame[:3, 3] = origin
    return frame


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
    """The datum's DMIS feature and DATDEF where it is a plane, else a comment."""
    if group.plane is None:
        return [f"$$ datum {group.label} ({group.face}) is no plane: no DMIS datum feature is written for it;",
                "$$+ its points are reported for cmmsampling.inspect, which associates it"]
    centre, normal = group.plane
    nominal = fixed(centre, COORDINATE_DECIMALS).tolist() + fixed(normal, VECTOR_DECIMALS).tolist()
    return (statement([f"F({group.feature})=FEAT/PLANE", "CART", *nominal[:3]], nominal[3:])
            + statement(["CONST/PLANE", f"F({group.feature})", "BF", *[f"FA({labels[k]})" for k in group.rows]])
            + [f"DATDEF/FA({group.feature}),DAT({group.label})"])


def frame_lines(groups: list[DatumGroup], statement) -> list[str]:
    """DATSET of the planar datums and the move to the CAD frame; comments where the datums
    are no planes or cannot set a frame."""
    if not groups or any(group.plane is None for group in groups):
        return ["$$ the datums are not all planes: the part's frame stays as the operator set it;",
                "$$+ cmmsampling.inspect aligns the reported points on the datums"] if groups else []
    try:
        frame = datum_frame([group.plane for group in groups if group.plane is not None])
    except ValueError as exc:
        return [f"$$ the datums set no frame here ({exc}): the part's frame stays as the operator set it"]
    fields = []
    for group, (direction, origin) in zip(groups, DATSET_WORDS):
        fields += [f"DAT({group.label})"] + ([direction] if direction else []) + [origin]
    back = np.eye(4)
    back[:3, :3] = frame[:3, :3].T
    back[:3, 3] = -frame[:3, :3].T @ frame[:3, 3]
    return (["$$ the frame the datums set, then the CAD model's frame in it"]
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
    datums = [f"DAT({group.label})" for group in groups if group.plane is not None]
    return VERDICT_COMMENT + [line for face in faces
                              for line in statement([f"T({tolerance_label(face)})=TOL/PROFS", *limits, *datums])]


def profile_lines(face: str, labels: list[str], statement) -> list[str]:
    """The face's points grouped and its profile reported: FEAT/PATERN, CONST/PATERN BUILD,
    OUTPUT with its TA."""
    return (statement([f"F({face})=FEAT/PATERN", *[f"F({label})" for label in labels]])
            + statement(["CONST/PATERN", f"F({face})", "BUILD", *[f"FA({label})" for label in labels]])
            + [f"OUTPUT/FA({face}),TA({tolerance_label(face)})"])
