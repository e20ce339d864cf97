"""QIF 3.0 datums: the DatumDefinitions of a datum reference frame and the frame itself, as a plan
made with datums and an inspection's results write them (:mod:`.plan`, :mod:`.results`), and the
profile characteristic's reference to the frame."""
from __future__ import annotations

from ...geometry.validation import InputError
from .xml import decimal, tag

# QIF's precedences of the datums of a frame, in order (a frame holds at most five).
PRECEDENCES = ("PRIMARY", "SECONDARY", "TERTIARY", "QUATERNARY", "QUINARY")
# A datum's criterion (cmmsampling.inspection.datums.DATUM_CRITERIA) as QIF's substitute feature algorithm.
DATUM_ALGORITHMS = {"tangent": "ONESIDED", "least_squares": "LEASTSQUARES"}
# Where a datum's points came from (its DatumDefinition's attribute ``points``): the measured
# file's points planned on its face, or its own (Datum.points).
PLANNED_POINTS, OWN_POINTS = "planned", "own"


def datum_definitions(doc, datums):
    """DatumDefinitions: per datum (a DatumFit, or any record with label, face, criterion and
    measurement None) its label and, as attributes, the label as given, its face's name and where
    its points came from (PLANNED_POINTS or OWN_POINTS). Returns [(element, id)] in precedence
    order (the writers add each datum's feature)."""
    holder = doc.add(doc.root, "DatumDefinitions", n=len(datums))
    defined = []
    for fit in datums:
        element, identifier = doc.with_id(holder, "DatumDefinition")
        own = fit.measurement is not None and fit.measurement.own
        doc.attributes(element, [("Str", "label", fit.label), ("Str", "face", fit.face),
                                 ("Str", "points", OWN_POINTS if own else PLANNED_POINTS)])
        doc.add(element, "DatumLabel", nmtoken(fit.label))
        defined.append((element, identifier))
    return defined


def nmtoken(label):
    """A datum label as xs:NMTOKEN takes it: characters other than letters, digits, '.', '-',
    '_' and ':' as '_' (the label as given is the definition's attribute ``label``)."""
    return "".join(c if c.isalnum() or c in ".-_:" else "_" for c in label) or "_"


def reference_frame(doc, datums, defined, cad_id):
    """The DatumReferenceFrame of the DatumFits in precedence order (their definitions:
    :func:`datum_definitions`), each datum simple, of the actual part, its criterion as the
    substitute feature algorithm; the frame's coordinate system cad_id (the CAD frame the part is
    aligned to; None: a plan's, none stated). Returns its id; InputError for more datums than QIF's precedences name (5)."""
    if len(datums) > len(PRECEDENCES):
        raise InputError(f"QIF 3.0 holds at most {len(PRECEDENCES)} datums in a frame, this inspection has "
                         f"{len(datums)}: judge the part on fewer datums to write its results")
    holder = doc.add(doc.root, "DatumReferenceFrames", n=1)
    frame, identifier = doc.with_id(holder, "DatumReferenceFrame")
    listed = doc.add(frame, "Datums", n=len(datums))
    for fit, (_, definition), precedence in zip(datums, defined, PRECEDENCES):
        datum = doc.add(listed, "Datum")
        simple = doc.add(datum, "SimpleDatum")
        doc.add(simple, "DatumDefinitionId", definition)
        doc.add(simple, "MaterialModifier", "NONE")
        doc.add(simple, "ReferencedComponent", "ACTUAL")
        doc.add(doc.add(simple, "SubstituteFeatureAlgorithm"), "SubstituteFeatureAlgorithmEnum",
                DATUM_ALGORITHMS[fit.criterion])
        doc.add(doc.add(datum, "Precedence"), "PrecedenceEnum", precedence)
    doc.add(frame, "Name", "|".join(fit.label for fit in datums))
    if cad_id is not None:
        doc.add(frame, "CoordinateSystemId", cad_id)
    return identifier


def framed_profile(doc, zone_offset, frame_id):
    """The profile characteristic's definition given its zone offset o (mm, ISO's UZ; none where
    0) and its datum reference frame (the frame's id; None for none)."""
    definition = doc.root.find("/".join(tag(name) for name in (
        "Characteristics", "CharacteristicDefinitions", "SurfaceProfileCharacteristicDefinition")))
    if zone_offset:
        doc.add(definition, "UnequallyDisposedZone", decimal(zone_offset))
    if frame_id is not None:
        doc.add(definition, "DatumReferenceFrameId", frame_id)
