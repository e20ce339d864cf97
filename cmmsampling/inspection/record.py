"""An inspection's record read back from its results QIF (:mod:`.results`), to judge the part
again as it was judged::

    record = cmmsampling.read_record("results.qif")
    again = record.inspect(plan, part=shape)     # the same datums, tolerance, zone, u, seed
    again.profile, again.profile_uncertainty, again.decision

What comes back: the measured points as read (contact points, mm, in the measured frame, with
their labels, in the order the inspection judged them: ``pointOrder``), the datum reference
frame (its ``DatumReferenceFrame`` in precedence order: each datum's label, face and criterion,
and the points of a datum that brought its own), the tolerance (the profile characteristic's
``ToleranceValue``), and the document's attributes for the rest: the alignment and its locked
motions, the zone offset, the probing uncertainty u and the Monte Carlo's seed; and, to compare
with, what the inspection found: its profile, U, the part's status and the alignment's transform.

Only documents that ``cmmsampling.export(inspection, "....qif")`` writes hold a record; any other
QIF file (another program's results, a plan, results written before the record was complete) is
refused in one line.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any
from xml.etree.ElementTree import Element

import numpy as np

from ..formats.files import read_text
from ..formats.pointset import PointSet
from ..formats.qif.read import RESULTS_METADATA, QIFDocument, parsed
from ..formats.qif.datum_frame import DATUM_ALGORITHMS, OWN_POINTS, PRECEDENCES
from ..formats.qif.results import PART_DECISION_STATUS
from ..formats.qif.xml import tag
from ..geometry.validation import InputError
from .datums import Datum

if TYPE_CHECKING:   # judge imports FreeCAD's Part: imported when a record is judged
    from .judge import Progress
    from .result import Inspection

# The attributes every record states (the others are stated where they apply).
RECORD_FACTS = ("alignment", "lockedMotions", "zoneOffset_mm", "profile_mm", "pointOrder")
RESULTS = "Results/MeasurementResultsSet/MeasurementResults"
CRITERIA = {algorithm: criterion for criterion, algorithm in DATUM_ALGORITHMS.items()}
DECISIONS = {status: decision for decision, status in PART_DECISION_STATUS.items()}


@dataclass(frozen=True)
class InspectionRecord:
    """What a results QIF records of an inspection.

    Asked: measured, a PointSet of the measured file's points that were judged (contact points,
    mm, measured frame; labels as measured, faces as planned; each datum's that came from the
    file first, then the toleranced ones); datums, the Datums of the frame in precedence order
    (label, face name, criterion; points: None where they are the measured file's, else a
    PointSet of the datum's own contact points); alignment, locked; tolerance (mm, None for
    none); zone_offset (mm); uncertainty: u, mm, the probing uncertainty (None for none); seed.
    Found: profile (mm), expanded_uncertainty (U, mm, None without u), status (the part's
    InspectionStatusEnum) and transform ((4, 4) measured -> CAD).
    """

    measured: PointSet
    datums: tuple[Datum, ...]
    alignment: str
    locked: tuple[str, ...]
    tolerance: float | None
    zone_offset: float
    uncertainty: float | None
    seed: int
    profile: float
    expanded_uncertainty: float | None
    status: str
    transform: np.ndarray

    @property
    def options(self) -> dict[str, Any]:
        """The keyword arguments of :func:`cmmsampling.inspect` that judge as the record did."""
        return {"alignment": self.alignment, "tolerance": self.tolerance, "locked": self.locked,
                "zone_offset": self.zone_offset, "datums": self.datums, "uncertainty": self.uncertainty,
                "seed": self.seed}

    @property
    def decision(self) -> str | None:
        """ISO 14253-1's decision the record states ('conforms', 'does not conform', 'undecided');
        None without a tolerance or an uncertainty."""
        if self.tolerance is None or self.uncertainty is None:
            return None
        return DECISIONS[self.status]

    def inspect(self, source: object, part: object = None, progress: Progress | None = None,
                **changes: Any) -> Inspection:
        """The part judged again: :func:`cmmsampling.inspect` of source (the plan, face or result
        the points were planned on; part=: the shape of a PartPlan) on the recorded points with
        the recorded :attr:`options`; changes: any of those options to judge otherwise (e.g.
        tolerance=0.04). InputError for another keyword."""
        from .judge import inspect

        unknown = sorted(set(changes) - set(self.options))
        if unknown:
            raise InputError(f"a record is judged again with its own settings, of which {', '.join(self.options)} "
                             f"may be changed; got {', '.join(unknown)}")
        return inspect(source, self.measured, part=part, progress=progress, **{**self.options, **changes})


def read_record(path: str | os.PathLike) -> InspectionRecord:
    """The InspectionRecord of a results QIF that ``cmmsampling.export(inspection, path)`` wrote.
    InputError in one line for a file that cannot be read (:func:`cmmsampling.formats.files.
    read_text`), is no valid QIF 3.0 document (:func:`.read.parsed`) or holds no complete record."""
    text = read_text(path, "QIF results file")
    name = os.fspath(path)
    document = QIFDocument(parsed(text, name))
    facts = _facts(document.root)
    missing = [fact for fact in RECORD_FACTS if fact not in facts]
    if missing:
        raise InputError(f"{name}: holds no complete inspection record (no {missing[0]} attribute): it is another "
                         "program's QIF, a plan, or results written before the record was complete; inspect the "
                         "measured points with cmmsampling.inspect, stating the settings")
    features = _feature_points(document, name)
    datums, own = _datums(document, features, name)
    probing = facts.get("probingUncertainty_mm")
    spread = facts.get("expandedUncertainty_mm")
    return InspectionRecord(
        _in_order([points for feature, points in features.items() if feature not in own], facts["pointOrder"], name),
        datums, facts["alignment"], tuple(json.loads(facts["lockedMotions"])), _tolerance(document),
        float(facts["zoneOffset_mm"]), None if probing is None else float(probing), int(facts.get("seed", 0)),
        float(facts["profile_mm"]), None if spread is None else float(spread),
        document.root.findtext(_path(f"{RESULTS}/InspectionStatus/InspectionStatusEnum"), ""),
        _transform(document.root, name))


def _path(names: str) -> str:
    """An ElementTree path of QIF names ('Results/MeasurementResultsSet')."""
    return "/".join(tag(name) for name in names.split("/"))


def _facts(root: Element) -> dict[str, str]:
    """{name: value} of the document's own attributes (QIFDocument/Attributes)."""
    return {element.get("name", ""): element.get("value", "") for element in root.findall(_path("Attributes/*"))}


def _attributes(element: Element) -> dict[str, str]:
    """{name: value} of an element's string attributes."""
    return {item.get("name", ""): item.get("value", "") for item in element.findall(_path("Attributes/AttributeStr"))}


def _feature_points(document: QIFDocument, name: str) -> dict[str, PointSet]:
    """{feature name: its points as read}: each MeasuredPointSet with a TranformId (ours: the
    points as read) as a PointSet of its points, labelled as planned (MeasurePointNominalIds).
    InputError where a set's ids are not its points' or name no planned point."""
    found: dict[str, PointSet] = {}
    for element in document.find_all(f"{RESULTS}/MeasuredPointSets/MeasuredPointSet"):
        if element.find(tag("TranformId")) is None:
            continue
        where = f'{name}: MeasuredPointSet id="{element.get("id")}"'
        try:
            points = np.array((element.findtext(tag("Points")) or "").split(), dtype=float).reshape(-1, 3)
        except ValueError:
            raise InputError(f"{where}: its Points are no list of x y z numbers; export the results again") from None
        named = [document.labels.get(identifier) for identifier in
                 (element.findtext(_path("MeasurePointNominalIds/Ids")) or "").split()]
        if len(named) != len(points) or not all(named):
            raise InputError(f"{where}: its MeasurePointNominalIds do not name a planned point per point; export the "
                             "results again")
        feature = named[0][1]
        found[feature] = PointSet([label for label, _ in named], points, np.full_like(points, np.nan),
                                  faces=[feature] * len(points))
    return found


def _datums(document: QIFDocument, features: dict[str, PointSet], name: str) -> tuple[tuple[Datum, ...], set[str]]:
    """(Datums in precedence order, the names of the features that hold datums' own points) of
    the document's DatumReferenceFrame (none: ((), set()))."""
    frame = document.root.find(_path("DatumReferenceFrames/DatumReferenceFrame"))
    if frame is None:
        return (), set()
    listed = sorted(frame.findall(_path("Datums/Datum")),
                    key=lambda datum: PRECEDENCES.index(datum.findtext(_path("Precedence/PrecedenceEnum"), "")))
    datums, own = [], set()
    for datum in listed:
        simple = datum.find(tag("SimpleDatum"))
        definition = document.by_id[simple.findtext(tag("DatumDefinitionId"), "")]
        stated = _attributes(definition)
        criterion = CRITERIA[simple.findtext(_path("SubstituteFeatureAlgorithm/SubstituteFeatureAlgorithmEnum"), "")]
        points = None
        if stated["points"] == OWN_POINTS:
            feature = document.by_id[definition.findtext(_path("FeatureNominalIds/Id"), "")].findtext(tag("Name"), "")
            if feature not in features:
                raise InputError(f"{name}: datum {stated['label']} brought its own points, but the file holds none "
                                 "of them; export the results again")
            points = features[feature]
            own.add(feature)
        datums.append(Datum(stated["label"], stated["face"], points, criterion))
    return tuple(datums), own


def _in_order(blocks: list[PointSet], order: str, name: str) -> PointSet:
    """One PointSet of the blocks' points in the order pointOrder (a JSON list of labels) states;
    InputError where it lists other points than the blocks hold."""
    labels = [label for block in blocks for label in block.labels]
    wanted = json.loads(order)
    where = {label: row for row, label in enumerate(labels)}
    if sorted(wanted) != sorted(labels) or len(where) != len(labels):
        raise InputError(f"{name}: its pointOrder attribute lists other points than the file's point sets hold; "
                         "export the results again")
    rows = np.array([where[label] for label in wanted], dtype=int)
    points = np.vstack([block.points for block in blocks])[rows]
    faces = [face for block in blocks for face in block.faces or []]
    return PointSet(wanted, points, np.full_like(points, np.nan), faces=[faces[row] for row in rows],
                    metadata={**RESULTS_METADATA, "path": os.path.abspath(name)})


def _tolerance(document: QIFDocument) -> float | None:
    """The profile tolerance t (mm) of the document's surface profile definition (None: none)."""
    value = document.root.findtext(_path("Characteristics/CharacteristicDefinitions/"
                                         "SurfaceProfileCharacteristicDefinition/ToleranceValue"))
    return None if value is None else float(value)


def _transform(root: Element, name: str) -> np.ndarray:
    """(4, 4) the alignment measured -> CAD of the document's Transform (:func:`.results.add_transform`);
    InputError where it has none."""
    element = root.find(_path("Transforms/Transform"))
    if element is None:
        raise InputError(f"{name}: holds no Transform (the alignment); export the results again")
    matrix = np.eye(4)
    for column, axis in enumerate("XYZ"):
        matrix[:3, column] = np.array(element.findtext(_path(f"Rotation/{axis}Direction"), "").split(), dtype=float)
    matrix[:3, 3] = np.array(element.findtext(tag("Origin"), "").split(), dtype=float)
    return matrix
