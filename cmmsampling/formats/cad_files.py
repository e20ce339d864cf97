"""Reading a CAD file (STEP, IGES, BREP) into a shape, and the one-line description of its faces
that ``python -m cmmsampling faces`` prints."""
import os

from ..geometry.validation import InputError
from .files import CAD_FILES, check_readable, check_size


# The CAD file types read_shape reads: {extension: FreeCAD's name for the format}
CAD_TYPES = {".step": "STEP", ".stp": "STEP", ".iges": "IGES", ".igs": "IGES", ".brep": "BREP",
             ".brp": "BREP"}


def read_shape(path):
    """The shape in a STEP, IGES or BREP file; InputError naming the problem otherwise (among them
    a path that is no regular file, refused before OCC opens it, and a file over
    :data:`cmmsampling.formats.files.CAD_FILES`)."""
    import Part

    extension = os.path.splitext(path)[1].lower()
    if extension not in CAD_TYPES:
        raise InputError(f"{path}: unknown file type {extension!r}; use a STEP, IGES or BREP file")
    path = check_readable(path, "CAD file")
    check_size(path, "CAD file", CAD_FILES)
    kind = CAD_TYPES[extension]
    try:
        shape = Part.read(path)
    except Exception as exc:   # OCC's reader raises a bare RuntimeError for any broken file
        raise InputError(f"{path}: cannot be read as {kind} ({freecad_reason(exc)}); check that the "
                         f"file is complete (not empty or cut short) and was exported as {kind}") from exc
    if not shape.Faces:
        raise InputError(f"{path}: the file holds no faces")
    return shape


def freecad_reason(exc):
    """The words of a FreeCAD exception: its message without the 'FreeCAD exception thrown' frame,
    or the 'sErrMsg' of the dict some FreeCAD versions raise."""
    detail = exc.args[0] if exc.args else exc
    if isinstance(detail, dict):
        detail = detail.get("sErrMsg") or detail.get("swhat") or detail
    text = str(detail)
    if text.startswith("FreeCAD exception thrown (") and text.endswith(")"):
        text = text[len("FreeCAD exception thrown ("):-1]
    return text


def describe_faces(shape):
    """One line per face: number, surface type, area (mm^2), size (mm), degrees and poles of its NURBS."""
    from ..geometry.domain import face_domain
    from ..geometry.surface import SurfaceModel

    lines = [f"{'face':>5} {'surface':<22} {'area mm^2':>11} {'size mm':>24} {'degree':>7} {'poles':>7} trimmed"]
    for number, face in enumerate(shape.Faces, start=1):
        model = SurfaceModel.from_face(face)
        box = face.BoundBox
        size = f"{box.XLength:.1f} x {box.YLength:.1f} x {box.ZLength:.1f}"
        poles = "x".join(str(p) for p in model.weights.shape)
        degree = "x".join(str(d) for d in model.degrees)
        trimmed = "yes" if face_domain(model).trimmed else "no"
        lines.append(f"{'Face' + str(number):>5} {type(face.Surface).__name__:<22} {face.Area:>11.2f} "
                     f"{size:>24} {degree:>7} {poles:>7} {trimmed}")
    return "\n".join(lines)
