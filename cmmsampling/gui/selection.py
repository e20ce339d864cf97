"""Which face the user selected, or a sentence saying what to select instead."""
import Part

from ..geometry.validation import InputError

NOTHING = "Nothing is selected: select one face of a part in the 3D view (or a one-face object in the tree)."
ELEMENT_KINDS = {"Edge": "an edge", "Vertex": "a vertex", "Facet": "a mesh facet"}


class SelectionError(InputError):
    """The selection is not exactly one face; the message says what to select."""


def selected_face(selection):
    """(obj, "FaceK") for a selection that is exactly one face of a shape.

    selection: Gui.Selection.getSelectionEx() (SelectionObjects with Object, SubElementNames).
    A whole object counts when its shape has exactly one face. Raises SelectionError otherwise.
    """
    if not selection:
        raise SelectionError(NOTHING)
    faces = [face for item in selection for face in faces_of(item.Object, item.SubElementNames)]
    if len(faces) != 1:
        names = ", ".join(f"{obj.Label}.{name}" for obj, name in faces)
        raise SelectionError(f"{len(faces)} faces are selected ({names}): select exactly one.")
    return faces[0]


def shape_of(obj):
    """obj's Part.Shape; SelectionError for meshes, point clouds and objects without a shape."""
    if obj.isDerivedFrom("Mesh::Feature") or obj.isDerivedFrom("Points::Feature"):
        raise SelectionError(
            f"{obj.Label} is a mesh or point cloud, which has no exact faces: select a face of a part "
            "(convert a mesh with Part > Create shape from mesh first)."
        )
    shape = getattr(obj, "Shape", None)
    if not isinstance(shape, Part.Shape) or shape.isNull():
        raise SelectionError(f"{obj.Label} has no shape: select a face of a part.")
    return shape


def faces_of(obj, names):
    """The (obj, "FaceK") named by a selection of obj's elements ``names`` (empty: the object).

    Raises SelectionError for meshes, objects without a shape and elements that are not faces.
    """
    shape = shape_of(obj)
    if not names:
        if len(shape.Faces) == 1:
            return [(obj, "Face1")]
        raise SelectionError(
            f"{obj.Label} has {len(shape.Faces)} faces: click the one to sample in the 3D view."
        )
    for name in names:
        if not name.startswith("Face"):
            kind = next((text for prefix, text in ELEMENT_KINDS.items() if name.startswith(prefix)),
                        "not a face")
            raise SelectionError(f"{obj.Label}.{name} is {kind}: select a face.")
    return [(obj, name) for name in names]


def selected_part_faces(selection):
    """(obj, [K, ...]): the faces of one part to plan, numbered from 1 as in "FaceK".

    selection: Gui.Selection.getSelectionEx(). Faces picked in the 3D view count as they are; a
    whole object (a solid picked in the tree) gives all its faces. Raises SelectionError for
    nothing selected, faces of several objects, and what :func:`faces_of` refuses.
    """
    if not selection:
        raise SelectionError("Nothing is selected: select faces of a part in the 3D view, or the whole "
                             "part in the tree.")
    chosen = {}
    for item in selection:
        obj = item.Object
        if item.SubElementNames:
            names = [name for _, name in faces_of(obj, item.SubElementNames)]
        else:
            names = [f"Face{k}" for k in range(1, len(shape_of(obj).Faces) + 1)]
        chosen.setdefault(obj, []).extend(names)
    if len(chosen) > 1:
        labels = ", ".join(obj.Label for obj in chosen)
        raise SelectionError(f"Faces of {len(chosen)} objects are selected ({labels}): a plan is made for "
                             "one part; select faces of one object, or one whole part.")
    [(obj, names)] = chosen.items()
    if not names:
        raise SelectionError(f"{obj.Label} has no faces to plan.")
    return obj, sorted({int(name[4:]) for name in names})
