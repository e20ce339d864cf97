"""Each characteristic of a QIF MBD model judged from the measured points of its plan
(``inspect(plan(read_mbd(path)), measured)``).

Every characteristic the plan holds is judged on its own, from the measured points on its faces
and on the faces of the datums it names, by :func:`cmmsampling.inspection.judge.inspect` (ISO
1101 zones, the points judged to the bounded faces):

- **SurfaceProfile**: relative to its datums in precedence order (ISO 5459: each datum fixes the
  motions the ones before it leave free; the zone floats in the rest), else best fit, minimum
  zone; the value is the zone's width about the nominal, 2 max |d|;
- **Flatness**: the points' minimum zone (two parallel planes, every motion floated), its width;
- **Perpendicularity, Parallelism, Angularity** of a planar face: the zone's orientation fixed
  by the datums, its location free: the width of the narrowest zone at that orientation.

A datum of planes with one outward normal (a face, or coplanar faces) is associated tangent (ISO
5459's default); a datum of other faces (a bore's halves, a pattern of holes, the two sides of a
slot) by least squares of its nominal geometry, its size kept. With a probing uncertainty each
value gets its expanded uncertainty U (Monte Carlo) and ISO 14253-1's decision. A characteristic
none of whose points was measured, or whose frame cannot be built from the points, has no value
and says why: it never conforms by default.
"""
from __future__ import annotations

import csv
import html
import io
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..formats.exporting import reordered
from ..formats.files import write_atomically
from ..formats.pointset import PointSet
from ..formats.qif.model import read_mbd
from ..geometry.freecad_env import import_part
from ..geometry.validation import InputError
from ..planning.mbd_plan import ModelCharacteristics
from .datums import Datum
from .judge import (InspectionCancelled, Planned, _measured_point_set, _planned, _positions, inspect, pair,
                    planned_face)
from .result import Inspection

Part = import_part()

# Kinds judged with the zone's location free (the datums fix its orientation only).
ORIENTATIONS = ("Perpendicularity", "Parallelism", "Angularity")
# Kinds judged without datums (a form tolerance).
FORMS = ("Flatness",)
# The first-article table's columns: (heading, key of CharacteristicResult.row()).
COLUMNS = (("Characteristic", "id"), ("Name", "name"), ("Type", "kind"), ("Tolerance mm", "tolerance"),
           ("Datums", "datums"), ("Faces", "faces"), ("Points", "points"), ("Measured mm", "value"),
           ("U mm", "uncertainty"), ("Decision", "decision"), ("Conforms", "conforms"))
# Datum faces whose outward normals agree to this (1 - cos) are one side: associated tangent.
SAME_SIDE = 1e-6


@dataclass
class CharacteristicResult:
    """One characteristic judged: characteristic (the model's record); value: mm, the
    measured zone width (None where it has no value: ``why``); passed: within the tolerance
    (None without a value); uncertainty: U mm (k = 2) where a probing uncertainty was given;
    decision: ISO 14253-1's ('conforms', 'does not conform', 'undecided') or None; points: the
    measured points on its faces; inspection: the Inspection it was judged by (None without a
    value); why: why it has no value ('' where it has one)."""

    characteristic: Any
    value: float | None
    passed: bool | None
    uncertainty: float | None = None
    decision: str | None = None
    points: int = 0
    inspection: Inspection | None = None
    why: str = ""

    @property
    def id(self) -> str:
        """The characteristic nominal's QIF id."""
        return self.characteristic.id

    @property
    def kind(self) -> str:
        """Its QIF type less 'CharacteristicNominal' ('Flatness')."""
        return self.characteristic.kind

    @property
    def tolerance(self) -> float:
        """Its tolerance, mm."""
        return self.characteristic.tolerance

    @property
    def conforms(self) -> str:
        """'yes', 'no', 'undecided' (ISO 14253-1 with the uncertainty) or 'not judged' (no value)."""
        if self.value is None:
            return "not judged"
        if self.decision is not None:
            return {"conforms": "yes", "does not conform": "no"}.get(self.decision, "undecided")
        return "yes" if self.passed else "no"

    def row(self) -> dict[str, str]:
        """The first-article table's row (COLUMNS' keys), figures as text."""
        c = self.characteristic
        zone = f" (UZ {c.zone_offset:+.4f})" if c.zone_offset else ""
        return {"id": c.id, "name": c.name, "kind": c.kind, "tolerance": f"{c.tolerance:.4f}{zone}",
                "datums": "|".join(c.datums), "faces": " ".join(c.faces), "points": str(self.points),
                "value": "" if self.value is None else f"{self.value:.4f}",
                "uncertainty": "" if self.uncertainty is None else f"{self.uncertainty:.4f}",
                "decision": self.decision or (self.why if self.value is None else ""), "conforms": self.conforms}


@dataclass
class MbdInspection:
    """A QIF MBD model's characteristics judged (:func:`inspect_mbd`): plan (the MbdPlan, or the
    ModelCharacteristics of a plan in a document),
    characteristics (a CharacteristicResult per characteristic planned, in the model's order),
    measured_file ('' for a PointSet), probing uncertainty u mm (None where none was given)."""

    plan: Any
    characteristics: list[CharacteristicResult]
    measured_file: str = ""
    probing_uncertainty: float | None = None
    notes: list = field(default_factory=list)

    @property
    def passed(self) -> bool | None:
        """False where any characteristic fails (or does not conform), None where any has no value
        or is undecided, else True."""
        verdicts = [result.conforms for result in self.characteristics]
        if "no" in verdicts:
            return False
        return True if verdicts and all(verdict == "yes" for verdict in verdicts) else None

    def not_judged(self) -> list[str]:
        """One line per characteristic of the model with no verdict here, and why."""
        return self.plan.not_planned() + [f"{r.id} {r.characteristic.name or r.kind} ({r.kind}): {r.why}"
                                          for r in self.characteristics if r.value is None]

    def rows(self) -> list[dict[str, str]]:
        """The first-article table's rows: the characteristics judged, then every other one of the
        model with its reason (nothing left out)."""
        rows = [result.row() for result in self.characteristics]
        planned = {result.id for result in self.characteristics}
        for c in self.plan.model.characteristics:
            if c.id not in planned:
                why = c.why_not or dict((u.id, w) for u, w in self.plan.unplanned).get(c.id, "")
                rows.append({"id": c.id, "name": c.name, "kind": c.kind,
                             "tolerance": "" if c.tolerance is None else f"{c.tolerance:.4f}",
                             "datums": "|".join(c.datums), "faces": " ".join(c.faces), "points": "",
                             "value": "", "uncertainty": "", "decision": why, "conforms": "not judged"})
        return rows

    def table(self) -> str:
        """The first-article table as text: one line per characteristic judged, then the verdict."""
        lines = [f"{'id':>6} {'kind':<18} {'tol mm':>8} {'datums':<7} {'pts':>4} {'value mm':>9} {'U mm':>7}  "
                 "conforms"]
        for result in self.characteristics:
            row = result.row()
            lines.append(f"{row['id']:>6} {row['kind']:<18} {row['tolerance']:>8} {row['datums'] or '-':<7} "
                         f"{row['points']:>4} {row['value'] or '-':>9} {row['uncertainty'] or '-':>7}  "
                         f"{row['conforms']}" + (f" ({result.why})" if result.why else ""))
        judged = sum(result.value is not None for result in self.characteristics)
        verdict = {True: "the part conforms", False: "the part does not conform",
                   None: "no verdict on the whole part"}[self.passed]
        lines.append(f"{judged} of {len(self.plan.model.characteristics)} characteristics judged; {verdict}")
        return "\n".join(lines)

    @property
    def labels(self) -> list[str]:
        """The labels of the measured points the characteristics were judged on."""
        seen = dict.fromkeys(label for result in self.characteristics if result.inspection is not None
                             for label in result.inspection.labels + [label for datum in result.inspection.datums
                                                                      if datum.measurement is not None
                                                                      for label in datum.measurement.labels])
        return list(seen)

    @property
    def profile(self) -> None:
        """None: each characteristic has its own value (``characteristics``)."""
        return None

    def write_csv(self, path: str | os.PathLike) -> str:
        """Write the first-article table (:meth:`rows`) as CSV; returns the path."""
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow([heading for heading, _ in COLUMNS])
        writer.writerows([[row[key] for _, key in COLUMNS] for row in self.rows()])
        write_atomically(path, out.getvalue(), "utf-8")
        return os.fspath(path)

    def write_html(self, path: str | os.PathLike) -> str:
        """Write the first-article table (:meth:`rows`) as an HTML page; returns the path."""
        head = "".join(f"<th>{html.escape(heading)}</th>" for heading, _ in COLUMNS)
        body = "\n".join("<tr class=\"" + row["conforms"].replace(" ", "-") + "\">"
                         + "".join(f"<td>{html.escape(row[key])}</td>" for _, key in COLUMNS) + "</tr>"
                         for row in self.rows())
        title = html.escape(f"First article: {os.path.basename(self.plan.model.path)}")
        page = (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>"
                "table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px}"
                ".no{background:#f4c7c3}.yes{background:#d9ead3}.undecided{background:#fce8b2}</style></head>\n"
                f"<body><h1>{title}</h1>\n<p>{html.escape(self.table().splitlines()[-1])}; measured points: "
                f"{html.escape(self.measured_file or 'given in hand')}</p>\n<table><tr>{head}</tr>\n{body}\n"
                "</table></body></html>\n")
        write_atomically(path, page, "utf-8")
        return os.fspath(path)


def inspect_mbd(mbd_plan: Any, measured: str | os.PathLike | PointSet, *, uncertainty: float | None = None,
                probe_radius: float | None = None, seed: int = 0,
                progress: Callable[[str | None], bool | None] | None = None) -> MbdInspection:
    """Judge every characteristic of an MbdPlan (cmmsampling.plan(read_mbd(...))) from the
    measured points (a path or PointSet, as :func:`cmmsampling.inspect` reads them; labels as
    planned, or in the planned order), as the module's doc says. uncertainty: u mm, the probing
    standard uncertainty per point (each value's U and ISO 14253-1 decision); probe_radius, seed
    and progress as inspect() takes them (progress's messages name the characteristic).
    Returns an MbdInspection."""
    return judge_model(mbd_plan, _planned(mbd_plan, mbd_plan.model.shape), measured, uncertainty, probe_radius,
                       seed, progress)


def inspect_model_group(group: Any, measured: str | os.PathLike | PointSet, *, uncertainty: float | None = None,
                        probe_radius: float | None = None, seed: int = 0,
                        progress: Callable[[str | None], bool | None] | None = None) -> MbdInspection:
    """:func:`inspect_mbd` of a plan of a QIF MBD model in a document (its group, whose MbdFile
    and Characteristics state the model and what was planned; its points, the planned ones),
    the model read again from its file (its faces named as the part read from it)."""
    if progress is not None and progress("reading the model's tolerances"):
        raise InspectionCancelled
    return inspect_model_file(group.MbdFile, planned_ids(group), group.Proxy.planned(group), measured, uncertainty=uncertainty, probe_radius=probe_radius,
                              seed=seed, progress=progress)


def planned_ids(group: Any) -> list[str]:
    """The ids of the characteristics a model's plan group states (its Characteristics lines)."""
    return [line.split()[0] for line in group.Characteristics]


def inspect_model_file(path: str, ids: Sequence[str], planned: Planned, measured: str | os.PathLike | PointSet, *,
                       uncertainty: float | None = None, probe_radius: float | None = None, seed: int = 0,
                       progress: Callable[[str | None], bool | None] | None = None) -> MbdInspection:
    """:func:`inspect_model_group` of its pieces (read from the document by the GUI thread): the
    model's file (path), the ids of the characteristics planned, and the planned points."""
    model = read_mbd(path)
    judged = model.judged()
    wanted = [c for c in judged if c.id in ids]
    record = ModelCharacteristics(model, wanted, [(c, "not in the document's plan") for c in judged if c.id not in ids],
                                  {label: tuple(model.datums[label].faces) for c in wanted for label in c.datums})
    return judge_model(record, planned, measured, uncertainty, probe_radius, seed, progress)


def judge_model(record: Any, planned: Planned, measured: str | os.PathLike | PointSet, uncertainty: float | None,
                probe_radius: float | None, seed: int,
                progress: Callable[[str | None], bool | None] | None) -> MbdInspection:
    """The MbdInspection of a model's characteristics (record: ModelCharacteristics, an MbdPlan
    among them) from the measured points of what was planned (planned: its Planned)."""
    read = _measured_point_set(measured)
    labelled, notes = _labelled(planned, read)
    results = []
    for k, c in enumerate(record.characteristics, start=1):
        def told(message: str | None, c: Any = c, k: int = k) -> bool | None:
            if progress is None:
                return None
            return progress(None if message is None else
                            f"characteristic {k} of {len(record.characteristics)} ({c.id} {c.kind}): {message}")

        results.append(judge_characteristic(c, record, planned, labelled, uncertainty, probe_radius, seed, told))
    return MbdInspection(record, results, os.fspath(measured) if isinstance(measured, (str, os.PathLike)) else "",
                         uncertainty, notes)


def judge_characteristic(c: Any, mbd_plan: Any, planned: Planned, measured: PointSet, uncertainty: float | None,
                         probe_radius: float | None, seed: int,
                         progress: Callable[[str | None], bool | None] | None = None) -> CharacteristicResult:
    """The CharacteristicResult of characteristic c from the measured points (a PointSet labelled
    as planned) on its faces and its datums' (planned: the whole plan's Planned)."""
    datums = () if c.kind in FORMS else tuple(_datum(label, mbd_plan) for label in c.datums)
    names = list(dict.fromkeys([*c.faces, *[name for datum in datums for name in _names(datum)]]))
    part = _subset(planned, names)
    assert part.labels is not None and part.owner is not None   # a plan's points have labels and faces
    face_of = {label.casefold(): part.names[owner].split(":")[-1] for label, owner in zip(part.labels, part.owner)}
    rows = np.flatnonzero([label.casefold() in face_of for label in measured.labels])
    touched = [face_of[measured.labels[row].casefold()] for row in rows]
    count = sum(face in c.faces for face in touched)
    if not count:
        return CharacteristicResult(c, None, None, why="none of the points on its faces was measured")
    unmeasured = [name for name in c.faces if name not in touched]
    if unmeasured:
        return CharacteristicResult(c, None, None, points=count,
                                    why=f"{unmeasured[0]} has no measured point: a verdict on the other faces would "
                                        "speak for it; measure it")
    try:
        found = inspect(part, reordered(measured, rows), "min_max", tolerance=c.tolerance, datums=datums,
                        probe_radius=probe_radius, uncertainty=uncertainty, seed=seed, progress=progress,
                        location_free=c.kind in ORIENTATIONS, zone_offset=c.zone_offset)
    except InputError as exc:
        return CharacteristicResult(c, None, None, points=count, why=str(exc))
    return CharacteristicResult(c, found.profile, found.passed, found.profile_uncertainty, found.decision,
                                count, found)


def _labelled(planned: Planned, measured: PointSet) -> tuple[PointSet, list[str]]:
    """(the measured points labelled as planned, the pairing's notes): pair() on the whole plan
    (by label, or by order where the file has none)."""
    order, notes = pair(planned, measured)
    assert planned.labels is not None   # a plan's points have labels
    return replace(reordered(measured, order[0]), labels=[planned.labels[row] for row in order[1]]), notes


def _subset(planned: Planned, names: Sequence[str]) -> Planned:
    """The Planned of the faces named (those with planned points), in that order."""
    indices = [index for index in (planned_face(planned, name) for name in names) if index is not None]
    assert planned.owner is not None and planned.points is not None and planned.labels is not None
    rows = np.isin(planned.owner, indices)
    return Planned([planned.labels[k] for k in np.flatnonzero(rows)], planned.points[rows],
                   [planned.faces[k] for k in indices], [planned.names[k] for k in indices],
                   _positions(indices)[planned.owner[rows]])


def _datum(label: str, mbd_plan: Any) -> Datum:
    """The Datum of the model's datum ``label``: its faces, tangent where they are planes facing
    one way, else least squares (see the module's doc)."""
    names = tuple(mbd_plan.datum_faces[label])
    faces = [mbd_plan.model.shape.getElement(name) for name in names]
    criterion = "tangent" if _one_side(faces) else "least_squares"
    return Datum(label, names[0] if len(names) == 1 else names, criterion=criterion)


def _one_side(faces: list) -> bool:
    """True where the faces are planes whose outward normals agree."""
    if not all(isinstance(face.Surface, Part.Plane) for face in faces):
        return False
    normals = np.array([_outward(face) for face in faces])
    return bool(np.all(normals @ normals[0] >= 1.0 - SAME_SIDE))


def _outward(face: Any) -> np.ndarray:
    """(3,) the planar face's outward unit normal (its orientation taken into account)."""
    u0, u1, v0, v1 = face.ParameterRange
    normal = face.normalAt(0.5 * (u0 + u1), 0.5 * (v0 + v1))
    return np.array([normal.x, normal.y, normal.z])


def _names(datum: Datum) -> tuple[str, ...]:
    """The face names of a Datum."""
    return datum.face if isinstance(datum.face, tuple) else (str(datum.face),)
