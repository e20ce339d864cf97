"""FreeCAD's File > Export hook for probe points (registered in Init.py)."""
from ..geometry.validation import InputError
from .object_types import is_part_plan, probe_points_in


def export(objects, filename):
    """FreeCAD's File > Export hook (registered in Init.py): write the one part plan's group
    among ``objects`` as one program of all its faces (along the probe's path where the plan was
    made with a probe), else the one probe-points object (directly or inside a Sampling group),
    with :func:`cmmsampling.export`; the format follows the file's extension (.dmi/.dmis DMIS,
    .xyz PC-DMIS XYZIJK, .csv CSV).

    Raises ValueError unless exactly one part plan's group or probe-points object is found.
    """
    from ..formats.exporting import export as write_points

    found = [obj for obj in objects if is_part_plan(obj)] or probe_points_in(objects)
    if len(found) != 1:
        raise InputError(f"select exactly one set of probe points (or its Sampling group, or a part plan's group) "
                         f"to export, found {len(found)}")
    source = found[0]
    with_path = is_part_plan(source) and source.Proxy.follows_probe(source)
    return write_points(source, filename, order="probe_path" if with_path else "as_optimised")
