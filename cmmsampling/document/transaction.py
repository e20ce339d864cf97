"""Undoable steps in a FreeCAD document: one transaction per action, rolled back on a fault."""
import contextlib

from .object_types import probe_points_in


def hide_results(doc):
    """Hide the probe points and substitute surfaces of every result in ``doc``.

    Within a transaction, call it after the transaction has added an object: FreeCAD records
    changes of Visibility for Undo only in a transaction that has begun with another change."""
    for obj in probe_points_in(doc.Objects):
        for shown in (obj, getattr(obj, "Substitute", None)):
            if shown is not None and shown.Visibility:
                shown.Visibility = False


@contextlib.contextmanager
def transaction(doc, name):
    """One undoable step named ``name``: commit when the block ends, roll back when it raises.

    On an exception the transaction is aborted, which removes the objects the block added and
    restores the properties it changed, and the exception is raised again. Undo is switched on for
    the time of the step when the document has it off (headless documents do), so that the
    rollback also works there; it is switched off again afterwards.
    """
    undo_mode = doc.UndoMode
    doc.UndoMode = 1
    doc.openTransaction(name)
    try:
        yield
    except BaseException:
        doc.abortTransaction()
        raise
    else:
        doc.commitTransaction()
    finally:
        doc.UndoMode = undo_mode


def recompute(doc, objects):
    """Recompute ``doc``; RuntimeError naming the first of ``objects`` whose computation failed
    (FreeCAD only marks such an object invalid)."""
    doc.recompute()
    for obj in objects:
        if "Invalid" in obj.State:
            raise RuntimeError(f"{obj.Label} could not be computed: {obj.getStatusString()}")
