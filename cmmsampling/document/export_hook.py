"""FreeCAD's File > Export hook for probe points (registered in Init.py)."""
import FreeCAD

from ..geometry.validation import InputError
from .export_defaults import export_call, starting_options
from .object_types import is_measured_points, is_part_plan, probe_points_in


def export(objects, filename):
    """FreeCAD's File > Export hook (registered in Init.py): write the one part plan's group
    among ``objects`` as one program of all its faces, else the one probe-points object (directly
    or inside a Sampling group), with :func:`cmmsampling.export` and the options the Export
    command's dialog starts from (cmmsampling.document.export_defaults.starting_options: along
    the probe's collision-free path with its ball radius where the points were planned with a
    probe), so that both commands write the same file; the format follows the file's extension
    (.dmi/.dmis DMIS, .xyz PC-DMIS XYZIJK, .csv CSV). The Report view gets the call that writes
    the same file and what was written.

    An inspection's measured points (or its group) are written as its results (QIF 3.0).
    Raises ValueError unless exactly one part plan's group, probe-points object or inspection is
    found.
    """
    from ..formats.exporting import export as write_points

    inspections = measured_points_in(objects)
    if inspections:
        return export_inspection(inspections, filename)
    found = [obj for obj in objects if is_part_plan(obj)] or probe_points_in(objects)
    if len(found) != 1:
        raise InputError(f"select exactly one set of probe points (or its Sampling group, or a part plan's group) "
                         f"to export, found {len(found)}")
    source = found[0]
    options = starting_options(source)
    report = write_points(source, filename, **options)
    FreeCAD.Console.PrintMessage(f"{report}\n(the same file as {export_call(source, filename, options)})\n")
    return report


def measured_points_in(objects):
    """The inspections' measured points among objects and inside selected groups."""
    found = []
    for obj in objects:
        for candidate in [obj] + list(getattr(obj, "Group", [])):
            if is_measured_points(candidate) and candidate not in found:
                found.append(candidate)
    return found


def export_inspection(inspections, filename):
    """Write the one inspection's results (cmmsampling.export of its Inspection, named after the
    part or points it measured); the Report view gets what was written."""
    from ..formats.exporting import export as write_results

    if len(inspections) != 1:
        raise InputError(f"select exactly one inspection to export its results, found {len(inspections)}")
    points = inspections[0]
    source = points.Source
    label = source.Label if source is not None else points.Document.Label
    report = write_results(points.Proxy.inspection(points), filename, label=label)
    FreeCAD.Console.PrintMessage(f"{report}\n")
    return report
