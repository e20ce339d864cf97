"""What the workbench's document objects are, told by their proxy's Type (FEM's way), and the
face that probe points were made on.

Both the document layer (cmmsampling.document) and the view providers (cmmsampling.gui) read
this module, so neither imports the other's classes: the view providers never import document.
"""
from ..geometry.freecad_env import import_part

Part = import_part()

PROBE_POINTS = "CMMSampling::ProbePoints"
SUBSTITUTE_SURFACE = "CMMSampling::SubstituteSurface"
PART_PLAN = "CMMSampling::PartPlan"
MEASURED_POINTS = "CMMSampling::MeasuredPoints"


def type_of(obj):
    """The Type of obj's Python proxy ('' for objects without one)."""
    return getattr(getattr(obj, "Proxy", None), "Type", "")


def is_probe_points(obj):
    """True for a probe-points object of this workbench."""
    return type_of(obj) == PROBE_POINTS


def is_substitute_surface(obj):
    """True for a substitute-surface object of this workbench."""
    return type_of(obj) == SUBSTITUTE_SURFACE


def is_measured_points(obj):
    """True for the measured points of an inspection (add_inspection_to_document)."""
    return type_of(obj) == MEASURED_POINTS


def is_part_plan(obj):
    """True for the group of a part plan made by this workbench (add_plan_to_document)."""
    return type_of(obj) == PART_PLAN


def in_document(obj, doc):
    """True when obj is an object of the FreeCAD document doc now: False once it was deleted
    (ReferenceError; where Undo still holds it, its Name raises RuntimeError on FreeCAD 0.20 and
    is None on 1.0) or when it is no document object."""
    try:
        name = obj.Name
        return isinstance(name, str) and obj.Document == doc and doc.getObject(name) == obj
    except (ReferenceError, RuntimeError, AttributeError):
        return False


def source_face(points):
    """The probe points' source face as it is now: (Part.Face, None), or (None, why not)."""
    if points.Source is None:
        if points.SourceName:
            return None, f"its source face {points.SourceName} was deleted"
        return None, "it was made without a source face"
    obj, names = points.Source
    name = names[0] if names else ""
    face = obj.getSubObject(name) if name else None
    if not isinstance(face, Part.Face):
        return None, f"{obj.Label} has no {name or 'face'} any more"
    return face, None


def probe_points_in(objects):
    """The probe-points objects among ``objects`` and inside those that are groups (a part plan's
    at any depth), once each."""
    found = []
    for obj in objects:
        inside = plan_probe_points(obj) if is_part_plan(obj) else list(getattr(obj, "Group", []))
        for candidate in [obj] + inside:
            if is_probe_points(candidate) and candidate not in found:
                found.append(candidate)
    return found


def plan_probe_points(group):
    """The probe-points objects of a part plan's group, face by face (its sub-groups in order)."""
    found = []
    for obj in group.Group:
        found += [obj] if is_probe_points(obj) else plan_probe_points(obj) if hasattr(obj, "Group") else []
    return found
