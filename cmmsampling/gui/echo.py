"""What the panels echo in the Python console: each action as the console API calls that
replay it as a macro (``Gui.doCommand``). A run made in a worker thread is handed over to its
echoed call (:mod:`cmmsampling.gui.handover`), so the echoed line binds its result without running
again here. The comparison's and the plan's engines are loaded (cmmsampling's lazy names) only by
the functions that echo them, so that Sample face does not load matplotlib."""
import __main__

import FreeCAD
import FreeCADGui

from ..access.probe import PROBES
from ..fitting.deviation import mm_text
from ..strategies import sampling
from . import counted
from .handover import handed


def source_text(source):
    """'Label.FaceK' of a source (obj, "FaceK")."""
    return f"{source[0].Label}.{source[1]}"


def call_text(arguments, expressions=None):
    """The arguments of an echoed call on ``face``: "face, n=49, strategy='pso', ..."; the
    arguments named in ``expressions`` as the console text given there (e.g. part= as its
    object's shape), the others by :func:`argument_text`."""
    expressions = expressions or {}
    return ", ".join(["face"] + [f"{key}={expressions.get(key) or argument_text(value)}"
                                 for key, value in arguments.items()])


def argument_text(value):
    """An argument as console text: a preset probe as cmmsampling.PROBES['...'], anything else
    as its repr."""
    name = next((name for name, probe in PROBES.items() if probe is value), None)
    return f"cmmsampling.PROBES[{name!r}]" if name is not None else repr(value)


def prior_expression(objects):
    """Console text of a part_error prior: the Inspections of the measured-points objects."""
    return "[" + ", ".join(f"{_object_expression(obj)}.Proxy.inspection({_object_expression(obj)})"
                           for obj in objects) + "]"


def _object_expression(obj):
    """App.getDocument('Doc').getObject('Name') for a document object."""
    return f"App.getDocument({obj.Document.Name!r}).getObject({obj.Name!r})"


def add_result(source, face, arguments, result, prior=None):
    """Write a finished run into the source's document through the console API; returns the
    result's group.

    The echo replays as a macro: ``face = ...``, ``result = cmmsampling.sample(face, ...)`` with
    the run's arguments, then ``add_to_document``. Here the sample() line does not run again: the
    run made in the worker thread is handed over to it (:func:`cmmsampling.gui.handover.handed`).
    face: the face the run was made on, as the panel took it from the source; prior: the console
    text of a part_error run's prior (:func:`prior_expression`), None without one.
    """
    obj, name = source
    doc = f"App.getDocument({obj.Document.Name!r})"
    source_expr = f"{doc}.getObject({obj.Name!r})"
    call = call_text(arguments, {"part": f"{source_expr}.Shape", "prior": prior})
    before = set(o.Name for o in obj.Document.Objects)
    FreeCADGui.doCommand("import cmmsampling")
    FreeCADGui.doCommand(f"face = {source_expr}.getSubObject({name!r})")
    with handed("sample", face, arguments, result):
        FreeCADGui.doCommand(f"result = cmmsampling.sample({call})")
    FreeCADGui.doCommand(
        f"group = cmmsampling.add_to_document(result, {doc}, source=({source_expr}, {name!r}))")
    return next(o for o in obj.Document.Objects
                if o.Name not in before and o.TypeId == "App::DocumentObjectGroup")


def report_run(source, result):
    """One line in the Report view for a finished run, and its notes below it."""
    FreeCAD.Console.PrintMessage(
        f"cmmsampling: {source}, {sampling.strategy_label(result.strategy)}, N = {result.n}: maximum deviation "
        f"{mm_text(result.deviation.maximum)}, mean {mm_text(result.deviation.mean)}, "
        f"{result.timings.get('total_s', 0.0):.1f} s\n")
    for note in result.notes:
        FreeCAD.Console.PrintMessage(f"cmmsampling: note: {note}\n")


def face_expression(source):
    """The console expression of a face (obj, "FaceK"), e.g.
    "App.getDocument('D').getObject('Body').getSubObject('Face1')"."""
    obj, name = source
    return f"App.getDocument({obj.Document.Name!r}).getObject({obj.Name!r}).getSubObject({name!r})"


def echo_study(face, run, alive=True):
    """Echo a study that ran in the panel in the Python console (the console holds it as
    ``study`` when its face is alive).

    face: the face's console expression (:func:`face_expression`), bound to ``face``; the study
    (run: the finished BackgroundComparison) is handed over to the echoed compare() call, so the
    line binds it without running again (replayed as a macro, it runs). A face deleted meanwhile
    (alive False) cannot be named: both lines are echoed as comments. The report written in the
    worker thread is handed over to the echoed ``report = cmmsampling.write_report(study, folder)``
    the same way (a comment too when the face is gone).
    """
    note = "ran in the task panel"
    if run.study.cancelled:
        note += f", cancelled after {counted(len(run.study.rows), 'run')} (a replay runs it whole)"
    call = call_text(run.arguments)
    FreeCADGui.doCommand("import cmmsampling")
    if alive:
        FreeCADGui.doCommand(f"face = {face}")
        with handed("compare", run.taken_face, run.arguments, run.study):
            FreeCADGui.doCommand(f"study = cmmsampling.compare({call})  # {note}")
    else:
        FreeCADGui.doCommand(f"# face = {face}  # deleted since")
        FreeCADGui.doCommand(f"# study = cmmsampling.compare({call})  # {note}")
    if run.report is not None and alive:
        with handed("write_report", run.study, {"folder": run.folder}, run.report):
            FreeCADGui.doCommand(f"report = cmmsampling.write_report(study, {run.folder!r})")
    elif run.report is not None:
        FreeCADGui.doCommand(f"# report = cmmsampling.write_report(study, {run.folder!r})  # ran in the task panel")


def add_plan(part, run, result, replace=None):
    """Write a finished plan into the part's document through the console API, echoed so that it
    replays as a macro: ``plan = cmmsampling.plan(<part>.Shape, ...)`` (for a QIF MBD model's
    plan, ``mbd = cmmsampling.read_mbd(<file>, shape=<part>.Shape)`` first, then
    ``cmmsampling.plan(mbd, ...)``; handed the model and the plan made in
    the worker thread, so it does not run again here; ``resume=plan`` where it resumed the
    cancelled plan the console's ``plan`` holds) and ``add_plan_to_document`` (replacing the
    group ``replace`` of that cancelled plan). Returns the plan's group."""
    doc = f"App.getDocument({part.Document.Name!r})"
    part_expr = f"{doc}.getObject({part.Name!r})"
    source, handed_source = f"{part_expr}.Shape", run.shape
    note = "ran in the task panel"
    if result.cancelled:
        note += f", cancelled after {counted(len(result.placed), 'face')} (a replay runs it whole)"
    FreeCADGui.doCommand("import cmmsampling")
    if run.model_file:
        with handed("read_mbd", run.model_file, {"shape": run.shape}, run.model):
            FreeCADGui.doCommand(f"mbd = cmmsampling.read_mbd({run.model_file!r}, shape={part_expr}.Shape)"
                                 "  # the part's QIF MBD model")
        source, handed_source = "mbd", run.model
    call = ", ".join([source] + [f"{key}={'plan' if key == 'resume' else argument_text(value)}"
                                 for key, value in run.arguments.items()])
    with handed("plan", handed_source, run.arguments, result):
        FreeCADGui.doCommand(f"plan = cmmsampling.plan({call})  # {note}")
    replacing = "" if replace is None else f", replace={doc}.getObject({replace.Name!r})"
    FreeCADGui.doCommand(f"group = cmmsampling.add_plan_to_document(plan, {doc}, {part_expr}{replacing})")
    return part.Document.getObject(__main__.group.Name)
