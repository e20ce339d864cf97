"""FreeCAD's File > Export hook for probe points (registered in Init.py)."""
import FreeCAD

from ..geometry.validation import InputError
from .export_defaults import export_call, starting_options
from .object_types import is_part_plan, probe_points_in


def export(objects, filename):
    """FreeCAD's File > Export hook (registered in Init.py): write the one part plan's group
    among ``objects`` as one program of all its faces, else the one probe-points object (directly
    or inside a Sampling group), with :func:`cmmsampling.export` and the options the Export
    command's dialog starts from (cmmsampling.document.export_defaults.starting_options: along
    the probe's collision-free path with its ball radius where the points were planned with a
    probe), so that both commands write the same file; the format follows the file's extension
    (.dmi/.dmis DMIS, .xyz PC-DMIS XYZIJK, .csv CSV). The Report view gets the call that writes
    the same file and what was written.

    Raises ValueError unless exactly one part plan's group or probe-points object is found.
    """
    from ..formats.exporting import export as write_points

    found = [obj for obj in objects if is_part_plan(obj)] or probe_points_in(objects)
    if len(found) != 1:
        raise InputError(f"select exactly one set of probe points (or its Sampling group, or a part plan's group) "
                         f"to export, found {len(found)}")
    source = found[0]
    options = starting_options(source)
    report = write_points(source, filename, **options)
    FreeCAD.Console.PrintMessage(f"{report}\n(the same file as {export_call(source, filename, options)})\n")
    return report
