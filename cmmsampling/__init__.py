"""cmmsampling: where a CMM's contact probe should touch a free-form face.

Scripting API (FreeCAD Python console, ``freecadcmd`` or ``/usr/bin/python3``)::

    import cmmsampling
    face = cmmsampling.reference_face()            # or obj.Shape.Faces[0]
    result = cmmsampling.sample(face, n=81, strategy="pso")
    result.points, result.normals, result.uv       # (N, 3) mm, (N, 3), (N, 2)
    result.deviation.maximum                       # mm
    result.substitute                              # Part.BSplineSurface
    sorted(cmmsampling.STRATEGIES)

Importing the package makes FreeCAD importable from Debian's Python and imports FreeCAD (not
Part: about 0.06 s); the names below are imported on first use, so that the numeric modules
(geometry, fitting, strategies) load without FreeCAD, e.g. in a worker process.

The method follows Zahmati & Amirabadi, Modares Mechanical Engineering 16(8), 55-64, 2016.
"""
import importlib

from .geometry.freecad_env import prepare_freecad

prepare_freecad()

_API = {
    "STRATEGIES": "strategies.sampling",
    "Strategy": "strategies.sampling",
    "Setting": "strategies.sampling",
    "InputError": "geometry.validation",
    "InputTypeError": "geometry.validation",
    "StrategyOutcome": "strategies.sampling",
    "register_strategy": "strategies.sampling",
    "FileFormat": "formats.pointfiles",
    "register_format": "formats.pointfiles",
    "unregister_format": "formats.pointfiles",
    "unregister_strategy": "strategies.sampling",
    "sample": "strategies.sampling",
    "evaluate": "strategies.sampling",
    "lower_bound": "strategies.sampling",
    "memory_needed": "strategies.estimates",
    "probe_edge_offset": "strategies.sampling",
    "time_needed": "strategies.estimates",
    "SamplingResult": "strategies.result",
    "SurfaceModel": "geometry.surface",
    "reference_face": "geometry.surface",
    "datum_block": "geometry.blocks",
    "default_pole_count": "fitting.substitute",
    "export": "formats.exporting",
    "ExportError": "formats.files",
    "measured_deviation": "measurement",
    "inspect": "inspection.inspecting",
    "Inspection": "inspection.result",
    "read_record": "inspection.record",
    "read_mbd": "formats.qif.model",
    "MbdModel": "formats.qif.model",
    "InspectionRecord": "inspection.record",
    "Datum": "inspection.datums",
    "points_for_verdict": "inspection.verdict_points",
    "simulate_measurement": "inspection.simulate",
    "simulated_series": "inspection.simulate",
    "measured_part": "inspection.simulate",
    "series_model": "inspection.series",
    "SeriesModel": "fitting.series",
    "self_contained": "strategies.sampling",
    "measure": "cmm.client",
    "MeasuredRun": "cmm.client",
    "MeasurementStopped": "cmm.client",
    "measure_until_decided": "cmm.decided",
    "DecidedRun": "cmm.decided",
    "SimulatedCMM": "cmm.server",
    "Misplacement": "inspection.simulate",
    "sanitise_labels": "formats.dmis",
    "read_points": "formats.pointfiles",
    "PointSet": "formats.pointset",
    "short_path": "geometry.probe_path",
    "Probe": "access.probe",
    "Motion": "access.probe",
    "PROBES": "access.probe",
    "probe_moves": "access.probe_moves",
    "points_needed": "planning.points_needed",
    "plan": "planning.plans",
    "MbdPlan": "planning.mbd_plan",
    "MbdInspection": "inspection.characteristics",
    "PartPlan": "planning.part_plan",
    "add_to_document": "document",
    "add_plan_to_document": "document",
    "add_inspection_to_document": "document",
    "reevaluate": "document",
    "compare": "study",
    "write_report": "study",
}

__all__ = sorted(_API)


def __getattr__(name):
    """Import the public API lazily (PEP 562)."""
    if name in _API:
        value = getattr(importlib.import_module(f".{_API[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'cmmsampling' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))
