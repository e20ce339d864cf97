"""Points out of a QIF 3.0 document: the measured points of a results file (ours or another
program's), else the planned points of a plan.

Measured points, in this order of preference:

- ``MeasuredPointSet``\\ s: ours pair each point with its planned ``MeasurePoint``
  (``MeasurePointNominalIds``) and so with its label (the feature item's ``pointLabels``); of
  the sets that hold the same planned points (ours: as read and as aligned) the one as read is
  taken. Another program's sets are labelled by the feature that lists them
  (``<feature>_P<i>``, or the feature's name for a set of one point), which pair by order;
- the ``DefiningPoints`` of feature measurements;
- the ``Location`` of point and edge point feature measurements (labelled by the feature's name).

Points a CMM left uncompensated (``Compensated`` false, with a ``ProbeRadius``) are ball
centres: the metadata states the radius (``probe_radius_mm``). A document that does not parse,
is not QIF 3.0 or that the QIF 3.0 schemas refuse (lxml checks; without it no QIF file is read)
is refused in one line,
as is one whose data disagree with their counts: a point set's ``count``, a list's ``n``, a
list of numbers that is no whole number of points, an id list of another length than the points,
with an id twice or an id of no element, two point sets that share some planned points but not
all.
"""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections import Counter
from typing import NamedTuple

import numpy as np

from ...geometry.validation import InputError
from ..pointset import PointSet
from .schema import UncheckedDocument, require_lxml, schema_errors
from .xml import tag

# The metadata of the measured points read from a results document.
RESULTS_METADATA = {"qif": "results"}
# What a refusal of a document's content asks for, unless it says otherwise.
CORRECT = "correct the file or export it again"
# The number lists of a MeasuredPointSet read, by name: numbers a row, what a row is.
SET_LISTS = {"Points": (3, "points"), "Normals": (3, "vectors"), "Deviations": (1, "deviations")}


def parsed(text, path):
    """The root of a QIF 3.0 document's text, checked by the schemas; InputError naming the file
    and the first problem (MissingPackage, before anything is parsed, without lxml)."""
    require_lxml()
    try:
        root = ET.fromstring(text.encode("utf-8"))
    except ET.ParseError as exc:
        raise InputError(f"{path}: not well-formed XML ({exc}); give a QIF 3.0 file") from None
    if root.tag != tag("QIFDocument"):
        raise InputError(f"{path}: not a QIF 3.0 document (its root element is {root.tag.split('}')[-1]!r} "
                         f"in {root.tag.split('}')[0].lstrip('{') or 'no namespace'}); give a QIF 3.0 file")
    try:
        errors = schema_errors(text)
    except UncheckedDocument as exc:
        raise InputError(f"{path}: {exc}") from None
    if errors:
        raise InputError(f"{path}: the QIF 3.0 schemas refuse it ({errors[0]}; {len(errors)} errors in all); "
                         "correct the file or export it again")
    return root


def read(text, path="<text>"):
    """PointSet of a QIF document's text: its measured points (metadata ``qif``: 'results') or,
    without any, its planned contact points (``qif``: 'plan'); InputError for a document with
    neither."""
    root = parsed(text, path)
    document = QIFDocument(root, path)
    point_set = document.measured()
    if point_set is None:
        point_set = document.planned()
    if point_set is None:
        raise InputError(f"{path}: a QIF document with neither measured nor planned points (a results file of "
                         "statuses only?); give the QIF results file that holds the measured points")
    return point_set


def _named(element):
    """An element as a message names it: its QIF name and id (``MeasuredPointSet id="47"``), or
    its name alone where it has no id."""
    name = element.tag.split("}")[-1]
    return f'{name} id="{element.get("id")}"' if element.get("id") else name


def _whole(text):
    """The int a count attribute states (None where it is absent or no whole number)."""
    try:
        return int(text)
    except (TypeError, ValueError):
        return None


class MeasuredSet(NamedTuple):
    """A MeasuredPointSet read and checked: its element, its name in messages, the planned ids it
    lists (() where none), points and vectors (M, 3), deviations (M,) mm (NaN where not given)
    and the ball radius of uncompensated points (0 for contact points)."""

    element: ET.Element
    name: str
    ids: tuple[str, ...]
    points: np.ndarray
    normals: np.ndarray
    deviations: np.ndarray
    radius: float


class QIFDocument:
    """A parsed QIF document: its elements by id, and the labels of planned points. path: the
    file's, for messages."""

    def __init__(self, root, path="<text>"):
        self.root = root
        self.path = path
        self.by_id = {element.get("id"): element for element in root.iter() if element.get("id")}
        self.labels = self._planned_labels()

    def refuse(self, problem, advice=CORRECT):
        """The InputError of a problem in the document: the file, the problem, what to do."""
        return InputError(f"{self.path}: {problem}; {advice}")

    def numbers(self, element, where, width=3):
        """The numbers of a list element's text as an (M, width) array; InputError naming
        ``where`` for a word that is no number or numbers that are no whole rows of width."""
        words = (element.text or "").split()
        try:
            values = np.array([float(word) for word in words], dtype=float)
        except ValueError:
            word = next(word for word in words if not _is_number(word))
            raise self.refuse(f"{where}: {word[:40]!r} is no number") from None
        if len(values) % width:
            raise self.refuse(f"{where} hold {len(values)} numbers, not a multiple of {width} (x y z a point)")
        return values.reshape(-1, width)

    def point(self, owner, child):
        """The one point or vector of owner's child element (Point, Location, Normal) as a (1, 3)
        array; InputError where it is missing or holds another count of numbers."""
        element = owner.find(tag(child))
        if element is None:
            raise self.refuse(f"{_named(owner)} has no {child}")
        values = self.numbers(element, f"the {child} of {_named(owner)}", 1)
        if len(values) != 3:
            raise self.refuse(f"the {child} of {_named(owner)} holds {len(values)} numbers, not 3 (x y z)")
        return values.reshape(1, 3)

    def value(self, owner, child, default, kind=float):
        """The number in owner's child element (kind: float or int), default where there is none;
        InputError where it is no number."""
        text = (owner.findtext(tag(child)) or "").strip()
        if not text:
            return default
        try:
            return kind(text)
        except ValueError:
            raise self.refuse(f"the {child} of {_named(owner)}: {text[:40]!r} is no number") from None

    def find_all(self, path):
        """Elements at a path of QIF names ('Features/FeatureItems/*')."""
        return self.root.findall("/".join(part if part == "*" else tag(part) for part in path.split("/")))

    def defining_points(self, feature):
        """The DefiningPoint elements of a feature nominal or measurement; InputError where its
        DefiningPoints list states another number (n)."""
        listed = feature.find(tag("DefiningPoints"))
        if listed is not None:
            held = len(listed.findall(tag("DefiningPoint")))
            if listed.get("n") is not None and _whole(listed.get("n")) != held:
                raise self.refuse(f'the DefiningPoints of {_named(feature)} say n="{listed.get("n")}" but hold '
                                  f"{held} DefiningPoint elements")
        return list(feature.iter(tag("DefiningPoint")))

    def _planned_labels(self):
        """{MeasurePoint or DefiningPoint id: (label, face)} from the feature items' point lists
        and the nominals' defining points, labels from ``pointLabels`` where written."""
        labels = {}
        for item in self.find_all("Features/FeatureItems/*"):
            name = item.findtext(tag("FeatureName"), "")
            written = self._point_labels(item)
            nominal = self.by_id.get(item.findtext(tag("FeatureNominalId"), ""))
            sets = [self.by_id.get(e.text) for e in item.iter(tag("WholePointSetId"))]
            for element in [s for s in sets if s is not None] + ([] if nominal is None else [nominal]):
                points = [p for p in element.iter() if p.tag in (tag("MeasurePoint"), tag("DefiningPoint"))]
                for index, point in enumerate(points):
                    label = written[index] if len(written) == len(points) else f"{name}_P{index + 1}"
                    labels[point.get("id")] = (label, name)
        return labels

    def _point_labels(self, item):
        """The labels we wrote on a feature item (its attribute ``pointLabels``, a JSON list), or
        []; InputError where the attribute is no JSON list."""
        for attribute in item.iter(tag("AttributeStr")):
            if attribute.get("name") == "pointLabels":
                try:
                    labels = json.loads(attribute.get("value", "[]"))
                except ValueError:
                    labels = None
                if not isinstance(labels, list):
                    raise self.refuse(f"the pointLabels attribute of {_named(item)} is no JSON list of labels")
                return [str(label) for label in labels]
        return []

    def measured(self):
        """The measured points as a PointSet (None where the document has none)."""
        sets = self.find_all("Results/MeasurementResultsSet/MeasurementResults/MeasuredPointSets/MeasuredPointSet")
        if sets:
            return self._from_sets(sets)
        defining = self.find_all("Results/MeasurementResultsSet/MeasurementResults/MeasuredFeatures/*")
        rows = [(p, m) for m in defining for p in self.defining_points(m)]
        if rows:
            return self._from_defining(rows)
        locations = [m for m in defining if m.tag in (tag("PointFeatureMeasurement"), tag("EdgePointFeatureMeasurement"))
                     and m.find(tag("Location")) is not None]
        if locations:
            names = [self._feature_name(m) or f"PT{index}" for index, m in enumerate(locations, start=1)]
            points = np.concatenate([self.point(m, "Location") for m in locations])
            return PointSet(names, points, np.full_like(points, np.nan), metadata=dict(RESULTS_METADATA))
        return None

    def _feature_name(self, measurement):
        """The FeatureName of a feature measurement's item ('' where none)."""
        item = self.by_id.get(measurement.findtext(tag("FeatureItemId"), ""))
        return "" if item is None else item.findtext(tag("FeatureName"), "")

    def _from_sets(self, sets):
        """PointSet of MeasuredPointSets (each checked, :meth:`_measured_set`): of sets listing
        the same planned points the first as read (with a TranformId), paired with the planned
        points' labels; the others labelled by the feature that lists them."""
        chosen = self._distinct([self._measured_set(element) for element in sets])
        listed = self._set_features()
        labels, faces = [], []
        for entry in chosen:
            named = [self.labels.get(i) for i in entry.ids]
            if named and all(named):
                labels += [label for label, _ in named]
                faces += [face for _, face in named]
            else:
                name = listed.get(entry.element.get("id"), f"SET{entry.element.get('id')}")
                count = len(entry.points)
                labels += [name] if count == 1 else [f"{name}_P{i}" for i in range(1, count + 1)]
                faces += [name] * count
        return self._point_set(labels, faces, [e.points for e in chosen], [e.normals for e in chosen],
                               [e.deviations for e in chosen], [e.radius for e in chosen])

    def _measured_set(self, element):
        """A MeasuredPointSet read as a MeasuredSet; InputError where its points are binary, its
        count or its lists disagree with its points (:meth:`_set_list`, :meth:`_nominal_ids`)."""
        name = _named(element)
        if element.find(tag("Points")) is None:
            raise self.refuse(f"{name} stores its points in binary (BinaryPoints), which this reader does not take",
                              "export the points as text")
        count = element.get("count")
        points = self._set_list(element, "Points", None if count is None else (_whole(count), f'says count="{count}"'))
        held = (len(points), f"holds {len(points)} points")
        normals = self._set_list(element, "Normals", held)
        deviations = self._set_list(element, "Deviations", held)
        compensated = element.findtext(tag("Compensated"), "true").strip() in ("true", "1")
        return MeasuredSet(element, name, self._nominal_ids(element, len(points)), points,
                           np.full_like(points, np.nan) if normals is None else normals,
                           np.full(len(points), np.nan) if deviations is None else deviations[:, 0],
                           0.0 if compensated else self.value(element, "ProbeRadius", 0.0))

    def _set_list(self, element, child, expected):
        """The rows of a MeasuredPointSet's number list (SET_LISTS: Points, Normals, Deviations),
        None where the set has none; expected: (the rows due, the words that say so), or None.
        InputError where the rows are not the number due."""
        given = element.find(tag(child))
        if given is None:
            return None
        width, noun = SET_LISTS[child]
        rows = self.numbers(given, f"the {child} of {_named(element)}", width)
        if expected is not None and len(rows) != expected[0]:
            raise self.refuse(f"{_named(element)} {expected[1]} but its {child} hold {len(rows)} {noun} "
                              f"({rows.size} numbers)")
        return rows

    def _nominal_ids(self, element, points):
        """The planned ids a MeasuredPointSet lists (MeasurePointNominalIds/Ids), () where none;
        InputError where their n or their number disagrees with them or with the set's points,
        or an id is listed twice or is no element's."""
        listed = element.find(tag("MeasurePointNominalIds"))
        given = None if listed is None else listed.find(tag("Ids"))
        if given is None:
            return ()
        ids = tuple((given.text or "").split())
        where = f"the MeasurePointNominalIds of {_named(element)}"
        if listed.get("n") is not None and _whole(listed.get("n")) != len(ids):
            raise self.refuse(f'{where} say n="{listed.get("n")}" but list {len(ids)} ids')
        if len(ids) != points:
            raise self.refuse(f"{where} list {len(ids)} ids for the set's {points} points")
        twice = [identifier for identifier, times in Counter(ids).items() if times > 1]
        if twice:
            raise self.refuse(f"{where} list id {twice[0]} twice")
        unknown = [identifier for identifier in ids if identifier not in self.by_id]
        if unknown:
            raise self.refuse(f"{where} list id {unknown[0]}, which no element of the file has")
        return ids

    def _distinct(self, read):
        """The MeasuredSets to take, in the document's order: of sets that list the same planned
        points (ours: as read and as aligned) the one with a TranformId (as read); InputError
        where two sets share some planned points but not all (a point would be read twice)."""
        order = sorted(range(len(read)), key=lambda k: read[k].element.find(tag("TranformId")) is None)
        kept, seen = [], set()
        for k in order:
            key = frozenset(read[k].ids)
            if key and key in seen:
                continue
            seen.add(key)
            kept.append(k)
        chosen = [read[k] for k in sorted(kept)]
        owners = {}
        for entry in chosen:
            for identifier in entry.ids:
                other = owners.setdefault(identifier, entry)
                if other is not entry:
                    raise self.refuse(f"{other.name} and {entry.name} both measure the planned point {identifier} but "
                                      "list different planned points", "keep one point set per planned point")
        return chosen

    def _set_features(self):
        """{MeasuredPointSet id: the name of the feature whose measurement lists it}."""
        listed = {}
        for measurement in self.find_all("Results/MeasurementResultsSet/MeasurementResults/MeasuredFeatures/*"):
            name = self._feature_name(measurement) or measurement.tag.split("}")[-1].replace("FeatureMeasurement", "")
            for reference in measurement.iter():
                if reference.tag.endswith("PointSetId") and reference.text:
                    listed.setdefault(reference.text.strip(), f"{name}{measurement.get('id')}")
        return listed

    def _point_set(self, labels, faces, blocks, normals, deviations, radii):
        """One PointSet of the blocks read; ball centres' radius in the metadata (one radius)."""
        metadata = dict(RESULTS_METADATA)
        stated = {radius for radius in radii if radius > 0}
        if len(stated) > 1:
            radii_mm = ", ".join(f"{r:g}" for r in sorted(stated))
            raise self.refuse(f"the QIF point sets hold ball centres of {len(stated)} probe radii ({radii_mm} mm)",
                              "inspect each probe's points alone")
        if stated:
            if len(set(radii)) > 1:
                raise self.refuse("the QIF point sets mix compensated contact points and ball centres",
                                  "inspect each kind alone")
            metadata["probe_radius_mm"] = stated.pop()
        if len(set(label.casefold() for label in labels)) < len(labels):
            labels = [f"P{i}" for i in range(1, len(labels) + 1)]
            metadata["labels"] = "by order"
        deviation = np.concatenate(deviations)
        return PointSet(labels, np.concatenate(blocks), np.concatenate(normals),
                        deviation=None if np.isnan(deviation).any() else deviation, metadata=metadata,
                        faces=faces)

    def _from_defining(self, rows):
        """PointSet of the DefiningPoints of feature measurements, labelled as their nominals."""
        labels, faces, points = [], [], []
        for point, measurement in rows:
            item = self.by_id.get(measurement.findtext(tag("FeatureItemId"), ""))
            nominal = None if item is None else self.by_id.get(item.findtext(tag("FeatureNominalId"), ""))
            sequence = self.value(point, "SequenceNumber", 0, int)
            planned = [] if nominal is None else self.defining_points(nominal)
            match = next((p for p in planned if self.value(p, "SequenceNumber", 0, int) == sequence), None)
            name = self._feature_name(measurement) or f"F{measurement.get('id')}"
            label, face = self.labels.get(None if match is None else match.get("id"), (f"{name}_P{sequence}", name))
            labels.append(label)
            faces.append(face)
            points.append(self.point(point, "Point"))
        block = np.concatenate(points)
        return self._point_set(labels, faces, [block], [np.full_like(block, np.nan)], [np.full(len(block), np.nan)],
                               [0.0])

    def planned(self):
        """The planned contact points of the feature nominals' DefiningPoints with their vectors
        (None where there are none); the probe's ball radius where the plan names a spherical tip."""
        labels, faces, points, normals = [], [], [], []
        for nominal in self.find_all("Features/FeatureNominals/*"):
            name = nominal.findtext(tag("Name"), "") or f"F{nominal.get('id')}"
            for point in self.defining_points(nominal):
                label, face = self.labels.get(point.get("id"), (f"{name}_P{len(labels) + 1}", name))
                labels.append(label)
                faces.append(face)
                points.append(self.point(point, "Point"))
                given = point.find(tag("Normal"))
                normals.append(self.point(point, "Normal") if given is not None else np.full((1, 3), np.nan))
        if not labels:
            return None
        metadata = {"qif": "plan"}
        sensor = self.root.find(f".//{tag('SimpleTactileProbeSensor')}[{tag('TipEndDiameter')}]")
        diameter = None if sensor is None else self.value(sensor, "TipEndDiameter", None)
        if diameter is not None:
            metadata["ball_radius_mm"] = diameter / 2.0
        return PointSet(labels, np.concatenate(points), np.concatenate(normals), metadata=metadata,
                        faces=faces if len(set(faces)) > 1 else None)


def _is_number(word):
    """True where a word reads as a float."""
    try:
        float(word)
    except ValueError:
        return False
    return True
