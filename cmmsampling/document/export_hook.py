"""FreeCAD's File > Export hook for probe points (registered in Init.py)."""
from ..geometry.validation import InputError
from .object_types import probe_points_in


def export(objects, filename):
    """FreeCAD's File > Export hook (registered in Init.py): write the one probe-points object
    among ``objects`` (directly or inside a Sampling group) with :func:`cmmsampling.export`; the
    format follows the file's extension (.dmi/.dmis DMIS, .xyz PC-DMIS XYZIJK, .csv CSV).

    Raises ValueError unless exactly one probe-points object is found.
    """
    from ..formats.exporting import export as write_points

    found = probe_points_in(objects)
    if len(found) != 1:
        raise InputError(f"select exactly one set of probe points (or its Sampling group) to export, "
                         f"found {len(found)}")
    return write_points(found[0], filename)
