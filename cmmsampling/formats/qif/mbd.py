"""The product and manufacturing information of a QIF 3.0 MBD document, as plain records.

A QIF MBD file states its tolerances as characteristics: a ``<Type>CharacteristicNominal``
(its id, name, designator, the feature nominals it applies to) refers to a
``<Type>CharacteristicDefinition`` (the tolerance: ``ToleranceValue`` for a geometric
tolerance, ``Tolerance`` Max/MinValue for a size; a datum reference frame; a zone shape, a
material condition). A feature nominal lists the B-rep faces it lies on
(``EntityInternalIds``); a datum definition (label A, B, ...) lists its feature nominals; a datum
reference frame lists datum definitions in precedence order (primary, secondary, tertiary).

Lengths carry their unit (``linearUnit="inch"``, a unit of the file's ``FileUnits``), else
the file's PMI linear unit, else its linear unit; every length here is in mm, with the figure
as the file wrote it (``tolerance_text``).

Every characteristic is read; :data:`JUDGED` names the kinds this tool judges from points on
faces, and every other one says why not (``why_not``).
"""
from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass, field

from ...geometry.validation import InputError
from .read import parsed
from .xml import tag

# Metres per unit for the unit names a file may use without stating a conversion.
SI_LENGTHS = {"meter": 1.0, "m": 1.0, "mm": 1e-3, "millimeter": 1e-3, "cm": 1e-2, "inch": 0.0254, "in": 0.0254,
              "ft": 0.3048, "micrometer": 1e-6, "um": 1e-6}
# The characteristic kinds this tool judges from points on faces, and how (docs/mbd.md).
JUDGED = {
    "SurfaceProfile": "the profile of the faces' measured points in the datum frame (best fit without datums)",
    "Flatness": "the range of the points' distances to their least-squares plane (never below the minimum zone)",
    "Perpendicularity": "the range of the points' distances along the face's normal, oriented by the datums",
    "Parallelism": "the range of the points' distances along the face's normal, oriented by the datums",
    "Angularity": "the range of the points' distances along the face's normal, oriented by the datums",
}
# Orientation tolerances are judged on planar faces with a planar zone only.
ORIENTATIONS = ("Perpendicularity", "Parallelism", "Angularity")
# Why a kind is not judged, by kind (else NOT_JUDGED).
WHY_NOT = {
    "Position": "the location of a feature of size (an axis, a centre plane) needs the feature's own fit",
    "Diameter": "a size needs the feature's own fit (a two-point or least-squares diameter)",
    "SphericalDiameter": "a size needs the feature's own fit (a two-point or least-squares diameter)",
    "Radius": "a size needs the feature's own fit",
    "SphericalRadius": "a size needs the feature's own fit",
    "Width": "a size needs the feature's own fit (two opposite faces)",
    "Length": "a size needs the feature's own fit",
    "DistanceBetween": "a distance between features needs their own fits",
    "Angle": "an angle between features needs their own fits",
    "Circularity": "the form of a section needs points along that section",
    "Cylindricity": "the form of a cylinder needs the cylinder's own fit",
    "Straightness": "the form of a line element needs points along that line",
}
NOT_JUDGED = "this tool does not judge this kind of characteristic"
# Kinds whose size (target, limits) is an angle, in degrees.
ANGULAR = ("Angle",)


@dataclass(frozen=True)
class Characteristic:
    """One characteristic nominal of an MBD document.

    id: the nominal's QIF id; kind: its QIF type less "CharacteristicNominal" ("SurfaceProfile",
    "Flatness", ...); name, designator: as the file names it ("" where it does not);
    tolerance: the zone's width for a geometric tolerance, mm (None for a size or a reference
    dimension); limits: (lower, upper) limits of a size, mm (None where not a size, or where its
    deviations have no target); target: the nominal size, mm (None where none); tolerance_text:
    the figures as the file writes them with their unit (and in mm); datums: the datum labels of its reference frame, primary
    first; features: its feature nominals' ids; face_ids: the QIF ids of the faces they lie on,
    in the file's order; zone: "diametrical", "planar", "spherical" or ""; material: the
    material condition ("NONE", "MAXIMUM", "LEAST" or ""); judged: whether this tool judges
    it; why_not: why not ("" when judged); unit: of target and limits ("mm", "degree");
    faces: the faces of the model's shape it applies to, FaceN as FreeCAD names them (set by
    :func:`cmmsampling.formats.qif.model.read_mbd`); zone_offset: mm, a profile zone's centre from
    the nominal, + out of the material (ISO 1101's UZ; from an ``UnequallyDisposedZone`` or an
    ``OuterDisposition`` d: d - t/2), 0 for a zone centred on it.
    """

    id: str
    kind: str
    name: str
    designator: str
    tolerance: float | None
    limits: tuple[float, float] | None
    target: float | None
    tolerance_text: str
    datums: tuple[str, ...]
    features: tuple[str, ...]
    face_ids: tuple[str, ...]
    zone: str = ""
    material: str = ""
    judged: bool = False
    why_not: str = ""
    unit: str = "mm"
    faces: tuple[str, ...] = ()
    zone_offset: float = 0.0


@dataclass(frozen=True)
class DatumRecord:
    """A datum definition: its label ("A"), QIF id, feature nominals' ids and their faces' QIF
    ids; faces: FaceN of the model's shape (set by :func:`cmmsampling.formats.qif.model.read_mbd`)."""

    label: str
    id: str
    features: tuple[str, ...]
    face_ids: tuple[str, ...]
    faces: tuple[str, ...] = ()


class CharacteristicList:
    """What the records of an MBD document and its model say of their ``characteristics``."""

    characteristics: list[Characteristic]

    def counts(self) -> Counter:
        """Characteristics by kind."""
        return Counter(c.kind for c in self.characteristics)

    def judged(self) -> list[Characteristic]:
        """The characteristics this tool judges."""
        return [c for c in self.characteristics if c.judged]

    def not_judged(self) -> list[str]:
        """One line per characteristic this tool does not judge: name, kind and why not."""
        return [f"{c.name or c.id} ({c.kind}): not judged: {c.why_not}" for c in self.characteristics if not c.judged]


@dataclass
class MbdRecords(CharacteristicList):
    """What an MBD document states: characteristics (one per nominal, in the file's order),
    datums (by label), the faces of its B-rep (QIF ids, in the file's order, with their labels),
    the file's length units (``linear``: its geometry's, ``pmi``: its tolerances' default) and
    mm per unit of each."""

    path: str
    characteristics: list[Characteristic]
    datums: dict[str, DatumRecord]
    face_ids: list[str]
    face_labels: dict[str, str]
    linear: str
    pmi: str
    mm_per_unit: dict[str, float] = field(default_factory=dict)



def read_mbd_records(path: str) -> MbdRecords:
    """The PMI of the QIF 3.0 MBD document at ``path`` (checked by the QIF schemas) as
    :class:`MbdRecords`; InputError naming the file and the problem when it is no
    QIF document, holds no characteristics, or refers to an id it does not hold."""
    return records_of(parsed_file(path), path)


def parsed_file(path: str) -> ET.Element:
    """The root of the QIF 3.0 document at path (:func:`cmmsampling.formats.qif.read.parsed`)."""
    try:
        with open(path, encoding="utf-8") as handle:
            text = handle.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot be read ({exc}); give a QIF 3.0 MBD file") from None
    return parsed(text, path)


def records_of(root: ET.Element, path: str) -> MbdRecords:
    """The records of a parsed MBD document (:func:`read_mbd_records`)."""
    try:
        return _records(root, path)
    except InputError as exc:
        raise InputError(str(exc) if str(exc).startswith(path) else f"{path}: {exc}") from None


def _records(root: ET.Element, path: str) -> MbdRecords:
    """The records of a parsed MBD document (see :func:`read_mbd_records`)."""
    nominals = root.find(f"{tag('Characteristics')}/{tag('CharacteristicNominals')}")
    if nominals is None or not len(nominals):
        raise InputError(f"{path}: holds no characteristics (no CharacteristicNominals): give a QIF MBD file "
                         "with the model's tolerances")
    by_id = {element.get("id"): element for element in root.iter() if element.get("id") is not None}
    units = _Units(root)
    faces = [face for face in root.iter(tag("Face")) if face.get("id") is not None]
    face_ids = [face.get("id", "") for face in faces]
    known_faces = set(face_ids)

    def lookup(ident: str, what: str) -> ET.Element:
        element = by_id.get(ident)
        if element is None:
            raise InputError(f"{path}: {what} refers to id {ident}, which the file does not hold; correct the file "
                             "or export it again")
        return element

    def feature_faces(feature_ids: tuple[str, ...], what: str) -> tuple[str, ...]:
        found: list[str] = []
        for ident in feature_ids:
            entities = _ids(lookup(ident, what), "EntityInternalIds")
            found += [face for face in entities if face in known_faces and face not in found]
        return tuple(found)

    datums = {}
    for definition in root.iter(tag("DatumDefinition")):
        label = _text(definition, "DatumLabel")
        features = _ids(definition, "FeatureNominalIds")
        datums[label] = DatumRecord(label, definition.get("id", ""), features,
                                    feature_faces(features, f"datum {label}"))
    labels_by_id = {record.id: label for label, record in datums.items()}
    characteristics = [_characteristic(nominal, lookup, feature_faces, labels_by_id, units) for nominal in nominals]
    return MbdRecords(path, characteristics, datums, face_ids, {face.get("id", ""): face.get("label", "") for face in faces},
                      units.linear, units.pmi, dict(units.mm))


def _characteristic(nominal, lookup, feature_faces, labels_by_id, units) -> Characteristic:
    """One characteristic nominal (an element) with its definition, as a Characteristic."""
    kind = nominal.tag.split("}")[-1].removesuffix("CharacteristicNominal")
    name = _text(nominal, "Name")
    what = f"characteristic {name or nominal.get('id')}"
    definition = lookup(_text(nominal, "CharacteristicDefinitionId"), what)
    features = _ids(nominal, "FeatureNominalIds")
    frame = _text(definition, "DatumReferenceFrameId")
    datums = _frame_labels(lookup(frame, what), labels_by_id) if frame else ()
    value = definition.find(tag("ToleranceValue"))
    tolerance = units.length(value) if value is not None else None
    text = "" if value is None else units.text(value)
    per_area = definition.find(f"{tag('ToleranceZonePerUnitArea')}/{tag('ToleranceValuePerUnit')}")
    if per_area is not None:
        text = f"{units.text(per_area)} per unit area"
    sized = units.angular() if kind in ANGULAR else units
    target_element = nominal.find(tag("TargetValue"))
    target = sized.length(target_element) if target_element is not None else None
    limits, size_text = _size_limits(definition.find(tag("Tolerance")), target, sized)
    text = size_text or text
    zone_shape = definition.find(tag("ZoneShape"))
    zone = "" if zone_shape is None or not len(zone_shape) else \
        zone_shape[0].tag.split("}")[-1].removesuffix("Zone").lower()
    faces = feature_faces(features, what)
    record = Characteristic(nominal.get("id", ""), kind, name, _text(nominal, "CharacteristicDesignator/Designator"),
                            tolerance, limits, target, text, datums, features, faces, zone,
                            _text(definition, "MaterialCondition"), unit=sized.base,
                            zone_offset=_zone_offset(definition, tolerance, units))
    why_not = _why_not(record, definition)
    return dataclasses.replace(record, judged=not why_not, why_not=why_not)


def _zone_offset(definition: ET.Element, tolerance: float | None, units: _Units) -> float:
    """A profile zone's centre from the nominal, mm, + out of the material: ISO's
    UnequallyDisposedZone as it is, ASME's OuterDisposition d (the zone's outer limit) as d - t/2;
    0 for a zone centred on the nominal."""
    centre = definition.find(tag("UnequallyDisposedZone"))
    if centre is not None:
        return units.length(centre)
    outer = definition.find(tag("OuterDisposition"))
    if outer is not None and tolerance is not None:
        return units.length(outer) - 0.5 * tolerance
    return 0.0


def _size_limits(tolerance: ET.Element | None, target: float | None,
                 units: _Units) -> tuple[tuple[float, float] | None, str]:
    """A size's (lower, upper) limits, mm, and their text: from its Tolerance's Min/MaxValue,
    limits themselves where DefinedAsLimit, else deviations from the target ((None, text) where
    the target is unknown); (None, "") without them."""
    if tolerance is None:
        return None, ""
    upper, lower = tolerance.find(tag("MaxValue")), tolerance.find(tag("MinValue"))
    if upper is None or lower is None:
        return None, ""
    if _text(tolerance, "DefinedAsLimit") == "true":
        return (units.length(lower), units.length(upper)), f"{units.text(lower)} to {units.text(upper)}"
    text = f"{units.text(lower)} / +{units.text(upper)}"
    if target is None:
        return None, text
    return (target + units.length(lower), target + units.length(upper)), text


def _why_not(record: Characteristic, definition: ET.Element) -> str:
    """Why this tool does not judge a characteristic ("" when it does)."""
    if record.kind not in JUDGED:
        if definition.find(tag("NonTolerance")) is not None:
            return "a reference dimension: it states no tolerance"
        return WHY_NOT.get(record.kind, NOT_JUDGED)
    if definition.find(tag("ToleranceZonePerUnitArea")) is not None:
        return "a tolerance per unit area is not judged (only over the whole face)"
    if record.tolerance is None or record.tolerance <= 0:
        return "it states no tolerance value"
    if _text(definition, "OffsetZone") == "true":
        return "an offset profile zone (ASME's OffsetZone) is not judged here"
    if not record.face_ids:
        return "its features lie on no face of the file's B-rep"
    if record.kind in ORIENTATIONS:
        if not record.datums:
            return "an orientation tolerance without a datum"
        if record.zone not in ("planar", ""):
            return f"an orientation of an axis ({record.zone} zone) needs the feature's own fit"
    return ""


def _frame_labels(frame: ET.Element, labels_by_id: dict[str, str]) -> tuple[str, ...]:
    """The datum labels of a datum reference frame, primary first (a compound datum "A-B")."""
    order = {"PRIMARY": 0, "SECONDARY": 1, "TERTIARY": 2}
    ranked = []
    for datum in frame.iter(tag("Datum")):
        precedence = _text(datum, "Precedence/PrecedenceEnum")
        labels = [labels_by_id.get(ident.text or "", "?") for ident in datum.iter(tag("DatumDefinitionId"))]
        if labels:
            ranked.append((order.get(precedence, len(order)), "-".join(labels)))
    return tuple(label for _, label in sorted(ranked, key=lambda pair: pair[0]))


class _Units:
    """A file's length units: ``linear`` (the geometry's), ``pmi`` (the tolerances' default) and
    ``mm`` (mm per unit, by unit name, from its FileUnits); ``base`` the unit values are given in
    ("mm"; "degree" for :meth:`angular`'s angles)."""

    base = "mm"
    attribute = "linearUnit"

    def __init__(self, root: ET.Element) -> None:
        self.root = root
        self.mm = {name: 1000.0 * metres for name, metres in SI_LENGTHS.items()}
        for unit in list(root.iter(tag("LinearUnit"))) + list(root.iter(tag("PMILinearUnit"))):
            name = _text(unit, "UnitName")
            factor = _text(unit, "UnitConversion/Factor")
            if name and factor:
                self.mm[name] = 1000.0 * float(factor)
        primary = root.find(f"{tag('FileUnits')}/{tag('PrimaryUnits')}")
        self.linear = _text(primary, "LinearUnit/UnitName") if primary is not None else ""
        self.linear = self.linear or "mm"
        self.pmi = (_text(primary, "PMILinearUnit/UnitName") if primary is not None else "") or self.linear

    def angular(self) -> _Units:
        """The file's angles: values in degrees (by ``angularUnit``, else its PMI angular unit)."""
        return _Angles(self.root)

    def unit(self, element: ET.Element) -> str:
        """The unit a value element is in: its unit attribute, else the PMI unit."""
        return element.get(self.attribute) or self.pmi

    def length(self, element: ET.Element) -> float:
        """A length element's value in mm; InputError for a unit the file does not define."""
        unit = self.unit(element)
        if unit not in self.mm:
            raise InputError(f"a length in {unit!r}, a unit the file does not define; correct the file's FileUnits")
        return float((element.text or "").strip()) * self.mm[unit]

    def text(self, element: ET.Element) -> str:
        """A length as the file writes it, with its unit, and in mm where that differs:
        '0.01 inch (0.254 mm)'."""
        figure, unit = (element.text or "").strip(), self.unit(element)
        if unit == self.base:
            return f"{figure} {unit}"
        return f"{figure} {unit} ({self.length(element):.6g} {self.base})"


class _Angles(_Units):
    """A file's angular units: values in degrees."""

    base = "degree"
    attribute = "angularUnit"

    def __init__(self, root: ET.Element) -> None:
        self.root = root
        self.mm = {"degree": 1.0, "deg": 1.0, "radian": 180.0 / 3.141592653589793}
        for unit in list(root.iter(tag("AngularUnit"))) + list(root.iter(tag("PMIAngularUnit"))):
            name, factor = _text(unit, "UnitName"), _text(unit, "UnitConversion/Factor")
            if name and factor and name not in self.mm:   # a file's degree is pi/180 cut to its digits
                self.mm[name] = float(factor) * 180.0 / 3.141592653589793
        primary = root.find(f"{tag('FileUnits')}/{tag('PrimaryUnits')}")
        self.linear = self.pmi = (_text(primary, "PMIAngularUnit/UnitName") if primary is not None else "") or "degree"


def _text(element: ET.Element | None, path: str) -> str:
    """The stripped text of a child element by path of QIF names ("A/B"), "" where absent."""
    if element is None:
        return ""
    found = element.find("/".join(tag(part) for part in path.split("/")))
    return "" if found is None or found.text is None else found.text.strip()


def _ids(element: ET.Element, name: str) -> tuple[str, ...]:
    """The ids of a child id list (``<name n=".."><Id>..</Id></name>``)."""
    listed = element.find(tag(name))
    return () if listed is None else tuple((ident.text or "").strip() for ident in listed.iter(tag("Id")))
