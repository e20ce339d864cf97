"""The options an export of probe points in the document starts from, whichever command writes it.

The Export command's dialog opens on them and File > Export writes with them, so that both give
the same program: points planned with the part and a probe that reaches them all go along the
collision-free probe path (DMIS: the probe's sensors and GOTO moves) with the probe's ball radius;
other points keep the order and radius of the last export (a short probe path and contact points
at first). The coordinates are in the frame of the last export where that frame belongs to this
document, else in its global frame. :func:`export_keywords` writes them as the keyword text of
the ``cmmsampling.export`` call that writes the same file.
"""
import json

from . import settings
from .object_types import is_part_plan, plan_probe_points

# Document objects that are coordinate systems; types unknown to this FreeCAD are never matched.
FRAME_TYPES = ("PartDesign::CoordinateSystem", "Part::LocalCoordinateSystem", "App::Placement")
DEFAULTS = {"ExportFrame": "", "ExportProbeRadius": 0.0, "ExportOrder": "short_path"}


def starting_options(points, stored=None):
    """{"frame": a coordinate system of the points' document or None (global), "probe_radius": mm,
    "order": 'as_optimised', 'short_path' or 'probe_path'}: keyword arguments of cmmsampling.export
    for a probe-points object or a part plan's group (see the module docstring). stored: the
    values of DEFAULTS' keys (None: as kept by the last export)."""
    stored = settings.load(DEFAULTS) if stored is None else stored
    doc, probe = points.Document, own_probe(points)
    frame = next((obj for obj in frame_objects(doc) if frame_setting(doc, obj.Name) == stored["ExportFrame"]), None)
    if points.Proxy.follows_probe(points):
        order = "probe_path"
    else:
        order = "short_path" if stored["ExportOrder"] == "probe_path" else stored["ExportOrder"]
    return {"frame": frame, "probe_radius": probe["ball_diameter"] / 2 if probe else stored["ExportProbeRadius"],
            "order": order}


def own_probe(points):
    """The probe settings (dict of cmmsampling.Probe's fields) probe points were sampled with (for
    a part plan's group: its first face's), or None."""
    members = plan_probe_points(points) if is_part_plan(points) else [points]
    text = getattr(members[0], "Probe", "") if members else ""
    return json.loads(text) if text else None


def frame_objects(doc):
    """The document's coordinate systems (FRAME_TYPES), in document order."""
    return [obj for obj in doc.Objects if any(obj.isDerivedFrom(kind) for kind in FRAME_TYPES)]


def frame_setting(doc, name):
    """The stored form of a frame: '<document's file or name>|<object name>' ('' for global)."""
    return f"{doc.FileName or doc.Name}|{name}" if name else ""


def frame_expression(obj):
    """The console expression of a document object, e.g. "App.getDocument('D').getObject('LCS')"."""
    return f"App.getDocument({obj.Document.Name!r}).getObject({obj.Name!r})"


def export_keywords(options):
    """The options of :func:`starting_options` as keyword text for the echoed export call, e.g.
    ", frame=App.getDocument('D').getObject('LCS'), probe_radius=1.5, order='short_path'";
    the defaults of cmmsampling.export (global frame, contact points, as optimised) are left out."""
    words = []
    if options["frame"] is not None:
        words.append(f"frame={frame_expression(options['frame'])}")
    if options["probe_radius"] > 0:
        words.append(f"probe_radius={options['probe_radius']!r}")
    if options["order"] != "as_optimised":
        words.append(f"order={options['order']!r}")
    return "".join(f", {word}" for word in words)


def export_call(points, path, options):
    """The console text of the cmmsampling.export call that writes ``points`` (a document object)
    to ``path`` with ``options`` (:func:`starting_options`)."""
    return (f"report = cmmsampling.export(App.getDocument({points.Document.Name!r}).getObject({points.Name!r}), "
            f"{path!r}{export_keywords(options)})")
