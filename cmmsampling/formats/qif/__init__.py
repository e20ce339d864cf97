"""QIF 3.0 (ISO 23952, the Quality Information Framework): measurement plans (:mod:`.plan`) and
inspection results (:mod:`.results`) written, points read back (:mod:`.read`), every document
checked against the official schemas (:mod:`.schema`, with lxml) before it is written."""
from ..registry import FileFormat
from . import plan, read, results
from .schema import schema_errors


class QIFSchemaError(RuntimeError):
    """A document the writers built does not pass the QIF 3.0 schemas (a defect of ours)."""


def checked(text):
    """The document's text once the QIF 3.0 schemas accept it; QIFSchemaError naming the first
    complaint otherwise, so nothing is written (MissingPackage without lxml, SchemaUnavailable
    without the schema files: nothing is written unchecked)."""
    errors = schema_errors(text)
    if errors:
        raise QIFSchemaError(f"the QIF document does not pass the QIF 3.0 schemas ({errors[0]}); nothing was "
                             "written: please report this with the points")
    return text


def unmeasured(point_set):
    """Why a QIF document's points are no measurement (a plan's), or None."""
    if point_set.metadata.get("qif") != "plan":
        return None
    return ("a QIF plan (planned points, no measured point set or feature measurement); give the QIF results file "
            "the CMM software wrote after measuring")


def write(point_set, facts, options):
    """A measurement plan of written probe points (:func:`.plan.write`), checked."""
    return checked(plan.write(point_set, facts, options))


def write_results(inspection, part):
    """The results of an Inspection (:func:`.results.write_results`), or of a QIF MBD model's
    characteristics (an MbdInspection: :func:`.mbd_results.write_mbd_results`, into the model's
    own document), checked."""
    if hasattr(inspection, "characteristics") and hasattr(inspection, "plan"):
        from .mbd_results import write_mbd_results

        return checked(write_mbd_results(inspection))
    return checked(results.write_results(inspection, part))


FORMAT = FileFormat(
    name="qif",
    title="QIF 3.0",
    description="QIF 3.0 plan or results (ISO 23952)",
    extensions=(".qif",),
    encoding="utf-8",
    write=write,
    read=read.read,
    contact_nominals=True,
    write_results=write_results,
    packages=("lxml",),
    unmeasured=unmeasured,
)
