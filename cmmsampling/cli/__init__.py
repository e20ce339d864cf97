"""Command line: sample faces headless with ``/usr/bin/python3 -m cmmsampling`` or ``freecadcmd``:
the parser, the sub-commands and the exit codes (what they print as they run: :mod:`.terminal`)."""
import argparse
import os
import re
import sys
import time
import traceback

from ..access.probe import PROBES
from ..formats.cad_files import describe_faces, freecad_reason, read_shape
from ..formats.files import remove_killed_saves
from ..formats.pointfiles import FORMATS
from ..geometry.surface import reference_face
from ..geometry.validation import InputError, check_real
from ..strategies.sampling import (BEST_STRATEGY, PROBE_EDGE_OFFSET_MM, STRATEGIES, probe_edge_offset, sample,
                                   self_contained)
from .terminal import FaceProgress, StudyProgress, TerminalProgress, format_table

# --probe's choices: the presets of cmmsampling.PROBES by their ball diameter (mm).
PROBE_CHOICES = {f"{probe.ball_diameter:g}": name for name, probe in PROBES.items()}
# The demo's virtual measurement: a 0.02 mm form error, 1 um probing noise, the part turned by
# up to a degree and shifted by up to 2 mm on the table; judged against a 0.1 mm profile.
DEMO_MEASUREMENT = {"form_error": 0.02, "noise": 0.001, "seed": 7,
                    "misplacement": {"rx": 0.4, "ry": -0.3, "rz": 0.9, "x": 1.2, "y": -2.0, "z": 0.5}}
DEMO_TOLERANCE = 0.1
# The datum block's profile tolerance relative to A | B | C (mm).
DEMO_DATUM_TOLERANCE = 0.05

DESCRIPTION = """Where should a CMM's contact probe touch a free-form face?

Places N probe points on a face with a sampling strategy, fits a least-squares B-spline
(the substitute geometry) to them and reports its deviation from the CAD face in mm.
Probe points are written with their approach vectors (unit outward normals; the probe
travels along -i,-j,-k) as {formats}.

examples:
  python -m cmmsampling faces part.step
  python -m cmmsampling sample part.step --face 3 -n 49 --out face3.dmi --out face3.csv
  python -m cmmsampling sample part.igs --face 1 --strategy pso --edge-offset 2 --fcstd out.FCStd
  python -m cmmsampling plan part.step --faces 1,3,5 --tolerance 0.05 --out plan.dmi --out plan.csv
  python -m cmmsampling plan part.step --points 300 --out plan.dmi --scheduler tcp://host:8786
  python -m cmmsampling sample part.step --face 3 -n 25 --probe 2 --out face3.dmi
  python -m cmmsampling demo"""


def formats():
    """The registered point-file formats in words, e.g. 'DMIS (.dmi, .dmis), CSV (.csv)'."""
    return ", ".join(f"{record.title} ({', '.join(record.extensions)})" for record in FORMATS.values())


def build_parser():
    """The argument parser with its sub-commands."""
    parser = argparse.ArgumentParser(prog="python -m cmmsampling", description=DESCRIPTION.format(formats=formats()),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--debug", action="store_true",
                        help="print the traceback of an error (for a bug report)")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    demo = commands.add_parser(
        "demo", help="sample the built-in reference surface with every strategy and print a table")
    demo.add_argument("-n", "--points", type=int, default=81, help="probe points per strategy (default 81)")
    _strategy_settings(demo)
    demo.add_argument("--seed", type=int, default=0, help="seed of the random parts (default 0)")
    demo.add_argument("--inspection", metavar="FOLDER", default="out/inspection",
                      help="then measure the points of the strategy with the smallest maximum on a virtual "
                           "CMM (a misplaced part with a form error), inspect them and write the file and "
                           "the colour map here (default out/inspection; 'none' skips it)")
    demo.add_argument("--report", metavar="FOLDER", default="out/report",
                      help="then compare every strategy over N = 25..144 and write the HTML report "
                           "with its figures here (default out/report; 'none' skips it; the demo's longest part)")
    faces = commands.add_parser("faces", help="list the faces of a STEP, IGES or BREP file")
    faces.add_argument("file", help="a .step/.stp, .iges/.igs or .brep/.brp file")
    one = commands.add_parser("sample", help="sample one face of a STEP, IGES or BREP file")
    _sample_arguments(one)
    part = commands.add_parser("plan", help="plan a whole part: every face (or --faces) to a tolerance "
                                            "or a total of points, in parallel, written as one program")
    _plan_arguments(part)
    return parser


def _plan_arguments(parser):
    """Arguments of the ``plan`` sub-command."""
    parser.add_argument("file", help="a .step/.stp, .iges/.igs or .brep/.brp file (lengths in mm)")
    parser.add_argument("--faces", type=_face_numbers, default=None, metavar="1,3,5",
                        help="the faces to plan, numbered as 'faces' lists them (default: all)")
    goal = parser.add_mutually_exclusive_group(required=True)
    goal.add_argument("--tolerance", type=float, metavar="MM",
                      help="each face gets the fewest points whose substitute deviates at most this")
    goal.add_argument("--points", type=int, metavar="N",
                      help="points for the whole part, spent where the worst face gains most")
    parser.add_argument("--strategy", default=BEST_STRATEGY, choices=self_contained(), metavar="STRATEGY",
                        help=f"where the points go on each face (default {BEST_STRATEGY})")
    parser.add_argument("--max-points", type=int, default=400, metavar="N",
                        help="with --tolerance, the most points a face may get (default 400)")
    _strategy_settings(parser)
    parser.add_argument("--processes", type=int, default=None, metavar="K",
                        help="local processes the faces run on (default: all cores)")
    parser.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                        help="run the faces on this Dask cluster instead of local processes")
    parser.add_argument("--out", action="append", default=[], metavar="FILE",
                        help=f"write all points as one program in one short probe path: {formats()} (CSV "
                             "with a face column); repeat for several files")
    parser.add_argument("--probe-radius", type=float, default=0.0, metavar="MM",
                        help="write ball centres instead of contact points (default 0; a DMIS program "
                             "keeps contact points and states the radius)")
    _probe_argument(parser)
    parser.add_argument("--fcstd", metavar="FILE",
                        help="also save a FreeCAD document: the part, one group per face, the plan's table")


def _probe_argument(parser):
    """--probe: a preset of cmmsampling.PROBES by its ball diameter."""
    presets = "; ".join(f"{ball}: {name}" for ball, name in PROBE_CHOICES.items())
    parser.add_argument("--probe", choices=list(PROBE_CHOICES), default=None, metavar="BALL_MM",
                        help="keep the points to where this probe reaches on the whole part in the file (its "
                             "stylus tilted where the normal is blocked), and write the collision-free path: "
                             f"{presets} (default: the reach is not judged)")


def probe_arguments(args, shape):
    """sample()'s and plan()'s part= and probe= for --probe (none without it)."""
    if args.probe is None:
        return {}
    return {"part": shape, "probe": PROBES[PROBE_CHOICES[args.probe]]}


def _face_numbers(text):
    """'1,3,5' -> [1, 3, 5]; argparse's error for anything else."""
    try:
        numbers = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"face numbers are whole numbers separated by commas, got {text!r}")
    if not numbers:
        raise argparse.ArgumentTypeError("give at least one face number")
    twice = sorted({number for number in numbers if numbers.count(number) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"face {twice[0]} is given twice; give each face once")
    return numbers


def _sample_arguments(parser):
    """Arguments of the ``sample`` sub-command."""
    parser.add_argument("file", help="a .step/.stp, .iges/.igs or .brep/.brp file (lengths in mm)")
    parser.add_argument("--face", type=int, required=True,
                        help="face number as 'faces' lists it (FreeCAD's FaceN)")
    parser.add_argument("-n", "--points", type=int, default=49, help="number of probe points (default 49)")
    parser.add_argument("--strategy", default=BEST_STRATEGY, choices=list(STRATEGIES),
                        metavar="STRATEGY",
                        help=f"where the points go (default {BEST_STRATEGY}, which goes furthest): "
                             + "; ".join(f"{name}: {entry.description}" for name, entry in STRATEGIES.items()))
    parser.add_argument("--edge-offset", type=float, default=None, metavar="MM",
                        help="distance every point keeps from the face's edges (default: the probe "
                             f"ball's radius plus a margin, {PROBE_EDGE_OFFSET_MM} mm, or on a narrower "
                             "face half its largest clearance; 0 allows edge points)")
    parser.add_argument("--min-spacing", type=float, default=None, metavar="MM",
                        help="smallest distance between two points, kept by every strategy "
                             "(default a tenth of the even spacing sqrt(area / N), at least 0.005 mm)")
    _strategy_settings(parser)
    parser.add_argument("--seed", type=int, default=0, help="seed of the random parts (default 0)")
    parser.add_argument("--prior", action="append", default=[], metavar="FILE",
                        help="part_error: the measured points of an earlier part of the series on this face (DMIS "
                             "output, CSV, XYZIJK or labelled x y z text, in the part's frame: read without "
                             "alignment); repeat for each earlier part")
    parser.add_argument("--out", action="append", default=[], metavar="FILE",
                        help=f"write the probe points; format from the extension: {formats()} "
                             "(repeat for several files)")
    parser.add_argument("--probe-radius", type=float, default=0.0, metavar="MM",
                        help="write ball centres (point + radius * normal) instead of contact points "
                             "(default 0: contact points; a DMIS program keeps contact points, its "
                             "FEAT/PTMEAS are surface points, and states the radius)")
    _probe_argument(parser)
    parser.add_argument("--order", default=None, choices=["as_optimised", "short_path", "probe_path"],
                        help="point order in the files: a short probe path, as optimised, or (with --probe) the "
                             "collision-free probe path with its moves (the default with --probe; short_path "
                             "without)")
    parser.add_argument("--fcstd", metavar="FILE", help="also save a FreeCAD document with the results")


def _strategy_settings(parser):
    """One argument per option that a strategy's record offers (Setting), each named once; unset
    (None) unless given, so that the strategy's own default applies."""
    offered = {}
    for entry in STRATEGIES.values():
        for setting in entry.settings:
            offered.setdefault(setting.option, setting)
    for option, setting in offered.items():
        parser.add_argument("--" + option.replace("_", "-"), type=setting.kind, default=None,
                            dest=option, help=setting.help)


def given_settings(name, args):
    """{option: value} of the settings of strategy ``name`` given on the command line."""
    return {s.option: getattr(args, s.option) for s in STRATEGIES[name].settings
            if getattr(args, s.option, None) is not None}


def strategy_options(name, args):
    """The options of strategy ``name`` given on the command line, with a progress display for an
    optimiser (a bar when its number of steps is known)."""
    entry = STRATEGIES[name]
    options = given_settings(name, args)
    if entry.optimiser:
        options["progress"] = TerminalProgress(entry.label, entry.progress_steps(options), entry.progress_unit)
    return options


def prior_inspections(face, paths):
    """The Inspections of earlier parts' measured files on face (a Part.Face), each read in the
    part's frame (no alignment): the series a part_error run learns from."""
    from ..inspection.judge import inspect

    return [inspect(face, path, alignment="none") for path in paths]


def finish_progress(options):
    """End the progress line of a run whose display had no known total (a bar ends itself)."""
    progress = options.get("progress")
    if progress is not None and progress.total is None:
        progress.finish()


def run_demo(args):
    """Every strategy on the reference surface; PSO with the paper's parameters. Ends with the
    wall time it took."""
    from ..strategies.estimates import duration_text

    start = time.perf_counter()
    face = reference_face()
    print(f"Reference surface: degree 5 x 5, 9 x 9 poles, 100 x 100 mm; N = {args.points}, "
          "substitute: bicubic, default poles; grid 60 x 60")
    results = []
    for name in self_contained():
        options = strategy_options(name, args)
        results.append(sample(face, args.points, name, seed=args.seed, **options))
        finish_progress(options)
    print(format_table(results))
    if args.inspection != "none":
        _inspection_loop(face, min(results, key=lambda r: r.deviation.maximum), args.inspection)
    if args.report != "none":
        _study_report(face, args)
    print(f"\nThe demo took {duration_text(time.perf_counter() - start)} on {os.cpu_count()} cores.")
    return 0


def _inspection_loop(face, result, folder):
    """The paper's loop after the program: a virtual CMM measures the result's points on a part
    with a form error, misplaced on the table (DEMO_MEASUREMENT); the measured points are read
    back, aligned by best fit and judged against DEMO_TOLERANCE; the file and the measured
    face's colour map go into folder."""
    from ..inspection.figure import write_inspection_figure
    from ..inspection.judge import inspect
    from ..inspection.simulate import simulate_measurement

    os.makedirs(folder, exist_ok=True)
    measured = simulate_measurement(result, os.path.join(folder, "measured.dmi"), **DEMO_MEASUREMENT)
    found = inspect(result, measured.path, tolerance=DEMO_TOLERANCE, uncertainty=DEMO_MEASUREMENT["noise"])
    print(f"\nInspection of the {STRATEGIES[result.strategy].label} points measured on a virtual CMM "
          f"({measured.path}), the CMM's probing uncertainty {DEMO_MEASUREMENT['noise']:g} mm per point:")
    print(found.summary())
    print(f"colour map: {write_inspection_figure(found, face, os.path.join(folder, 'deviation.png'))}")
    _live_measurement(result, folder, found)
    _datum_inspection(folder)


def _datum_inspection(folder):
    """A profile relative to datums A | B | C: the datum block's top and its three planar sides
    planned together (16 points a face), measured on the virtual CMM (DEMO_MEASUREMENT: the
    same form error, noise and misplacement), aligned on the datums, judged with its
    uncertainty."""
    from ..geometry.blocks import DATUM_FACES, TOP, datum_block
    from ..inspection.judge import inspect
    from ..inspection.simulate import simulate_measurement
    from ..planning.part_plan import plan
    from ..strategies.registry import baseline

    block = datum_block()
    planned = plan(block, n_total=64, strategy=baseline(), faces=[3, 1, 5, 4], processes=1)
    measured = simulate_measurement(planned, os.path.join(folder, "measured_block.dmi"), **DEMO_MEASUREMENT)
    found = inspect(planned, measured.path, part=block, tolerance=DEMO_DATUM_TOLERANCE, datums=DATUM_FACES,
                    uncertainty=DEMO_MEASUREMENT["noise"])
    print(f"\nThe datum block's top ({TOP}) measured with its datums A = {DATUM_FACES[0]}, B = {DATUM_FACES[1]}, "
          f"C = {DATUM_FACES[2]} ({measured.path}), profile {DEMO_DATUM_TOLERANCE:g} | A | B | C:")
    print(found.summary())


def _live_measurement(result, folder, filed):
    """The same points measured live: the simulated I++ DME server (the same virtual part) on
    127.0.0.1, the client's session, its transcript and the inspection of what it measured,
    beside the file route's."""
    from ..cmm.client import measure
    from ..cmm.server import SimulatedCMM, VirtualPart
    from ..inspection.judge import inspect

    part = VirtualPart.of(result, **DEMO_MEASUREMENT)
    with SimulatedCMM(part) as cmm:
        run = measure(result, cmm.address, os.path.join(folder, "measured_live.csv"),
                      log=os.path.join(folder, "ippdme_session.log"))
    found = inspect(result, run, tolerance=DEMO_TOLERANCE)
    print(f"\nMeasured live over I++ DME: {run}\nsession transcript: {os.path.join(folder, 'ippdme_session.log')}")
    print(f"profile {found.profile:.4f} mm (the file route: {filed.profile:.4f} mm), "
          f"{'PASS' if found.passed else 'FAIL'}")


def _study_report(face, args):
    """Every strategy over the default N list (the paper's Table 1 and Fig. 9-13) as an HTML report."""
    from ..study import write_report
    from ..study import compare

    progress = StudyProgress()
    options = {name: given_settings(name, args) for name in STRATEGIES}
    study = compare(face, seeds=(args.seed, args.seed + 1, args.seed + 2, args.seed + 3, args.seed + 4),
                    options={name: values for name, values in options.items() if values}, progress=progress)
    progress.finish()
    print(study.table())
    print(f"report: {write_report(study, args.report)}")


def run_faces(args):
    """List the faces of a CAD file."""
    print(describe_faces(read_shape(args.file)))
    return 0


def run_sample(args):
    """Sample one face of a CAD file and write what was asked for."""
    _check_outputs(args)
    if args.order == "probe_path" and args.probe is None:
        raise InputError("--order probe_path needs --probe (the probe whose path keeps clear of the part)")
    shape = read_shape(args.file)
    if not 1 <= args.face <= len(shape.Faces):
        raise InputError(f"--face must be between 1 and {len(shape.Faces)} for {args.file}, got {args.face}")
    if "prior" in STRATEGIES[args.strategy].requires and not args.prior:
        raise InputError(f"{args.strategy} learns where the series' parts err from earlier parts: give --prior FILE "
                         "(an earlier part's measured points on this face) once per part")
    options = strategy_options(args.strategy, args)
    face = shape.Faces[args.face - 1]
    if args.prior:
        options["prior"] = prior_inspections(face, args.prior)
    edge_offset = probe_edge_offset(face) if args.edge_offset is None else args.edge_offset
    result = sample(face, args.points, args.strategy, seed=args.seed,
                    edge_offset=edge_offset, min_spacing=args.min_spacing, **probe_arguments(args, shape), **options)
    finish_progress(options)
    print(f"{os.path.basename(args.file)} Face{args.face}: {args.strategy}, N = {result.n}, "
          f"edge offset {edge_offset:g} mm{' (default for this face)' if args.edge_offset is None else ''}, "
          f"spacing {result.settings['min_spacing']:.3g} mm")
    for note in result.notes:
        print(f"Note: {note}")
    print(format_table([result]))
    _write_outputs(result, args)
    return 0


def run_plan(args):
    """Plan the faces of a CAD file and write the program and the document asked for."""
    from ..document import add_plan_to_document
    from ..formats.exporting import export
    from ..planning.part_plan import plan

    _check_outputs(args)
    shape = read_shape(args.file)
    options = given_settings(args.strategy, args)
    progress = FaceProgress()
    result = plan(shape, tolerance=args.tolerance, n_total=args.points, strategy=args.strategy, faces=args.faces,
                  n_max=args.max_points, processes=args.processes, scheduler=args.scheduler, progress=progress,
                  probe=probe_arguments(args, shape).get("probe"), **options)
    progress.finish()
    goal = f"tolerance {args.tolerance:g} mm" if args.tolerance is not None else f"{args.points} points"
    print(f"{os.path.basename(args.file)}: {len(result.faces)} faces, {goal}, {args.strategy}: "
          f"{result.n_total} points on {len(result.placed)} faces in {result.seconds:.1f} s")
    print(result.table())
    order = "probe_path" if args.probe and result.placed and not any(f.unreached for f in result.placed) else "short_path"
    for path in args.out:
        print(export(result, path, probe_radius=args.probe_radius, order=order, label=os.path.basename(args.file)))
    if args.fcstd:
        _save_document(args, lambda document, part: add_plan_to_document(result, document, part))
    return 0


def _check_outputs(args):
    """ValueError or OSError before any computation when an output cannot be written: an
    unknown point-file extension, an --fcstd name without .FCStd, a folder that takes no file."""
    from ..formats.files import check_writable
    from ..formats.pointfiles import resolve_format

    check_real("--probe-radius", args.probe_radius, 0.0)
    for path in args.out:
        try:
            resolve_format(path)
        except InputError:
            raise InputError(f"--out {path}: unknown point-file type; end the name in one of "
                             f"{formats()}") from None
        check_writable(path)
    if args.fcstd:
        if not args.fcstd.lower().endswith(".fcstd"):
            raise InputError(f"--fcstd {args.fcstd}: a FreeCAD document's name ends in .FCStd")
        check_writable(args.fcstd)


def _write_outputs(result, args):
    """Point files and the optional FreeCAD document."""
    from ..formats.exporting import export
    from ..formats.pointset import PointSet

    label = f"{os.path.basename(args.file)}:Face{args.face}"
    order = args.order or ("probe_path" if args.probe else "short_path")
    source = result if order == "probe_path" else PointSet.from_result(result, label)
    for path in args.out:
        print(export(source, path, probe_radius=args.probe_radius, order=order, label=label))
    if args.fcstd:
        from ..document import add_to_document

        _save_document(args, lambda document, part: add_to_document(result, document,
                                                                   source=(part, f"Face{args.face}")))


def _save_document(args, add):
    """Save a new FreeCAD document (args.fcstd) holding the source shape (args.file) and what
    ``add(document, part)`` adds to it."""
    import FreeCAD

    document = FreeCAD.newDocument("cmmsampling")
    try:
        part = document.addObject("Part::Feature", os.path.splitext(os.path.basename(args.file))[0])
        part.Shape = read_shape(args.file)
        document.recompute()
        add(document, part)
        for leftover in remove_killed_saves(args.fcstd):
            print(f"removed {leftover}, left by a save that was killed midway")
        try:
            document.saveAs(os.path.abspath(args.fcstd))
        except Exception as exc:   # FreeCAD raises its own exception types here
            raise OSError(f"could not save {args.fcstd}: {freecad_reason(exc)}") from exc
        print(f"saved {args.fcstd}")
    finally:
        FreeCAD.closeDocument(document.Name)


def main(argv=None):
    """Entry point; returns the process exit code: 2 for bad input (a file, path or value, with one
    line saying what to do), 1 for anything unexpected; a traceback only with --debug."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = {"demo": run_demo, "faces": run_faces, "sample": run_sample, "plan": run_plan}[args.command](args)
        sys.stdout.flush()   # here, so that a reader gone early is met inside this try
        return code
    except InputError as exc:
        return _fail(args, f"error: {option_words(str(exc), parser, args.command)}", 2)
    except BrokenPipeError:   # the output's reader left (e.g. "| head"): stop quietly, as SIGPIPE would
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return BROKEN_PIPE
    except OSError as exc:
        return _fail(args, f"error: {exc}", 2)
    except MemoryError:
        return _fail(args, "error: this run needs more memory than the machine has free; lower -n "
                           "(or --population for PSO)", 2)
    except KeyboardInterrupt:
        return _fail(args, "interrupted", 130)
    except Exception as exc:
        return _fail(args, f"error: unexpected {type(exc).__name__}: {exc}; run again with --debug "
                           "for the details and report them", 1)


# The exit code of a run whose output's reader left early: 128 + SIGPIPE, as a shell reports it.
BROKEN_PIPE = 141

# The API's argument names that a command-line option of another name sets.
API_NAMES = {"n": "points", "n_total": "points", "n_max": "max_points"}


def option_words(message, parser, command):
    """An API message in the command line's words: in a message that starts with an argument's name
    and what is wrong with it (``n_max (10) is below...``, ``population must be...``,
    ``grid[0] must...``), that name becomes its option (``--max-points``) throughout."""
    name = re.match(r"[a-z_]+(?= must |\[| \()", message)
    if name is None:
        return message
    dest = API_NAMES.get(name.group(), name.group())
    for action in _subparser(parser, command)._actions:
        if action.dest == dest and action.option_strings:
            return re.sub(rf"\b{name.group()}\b(?!=)", max(action.option_strings, key=len), message)
    return message


def _subparser(parser, command):
    """The parser of one sub-command."""
    return next(action for action in parser._actions
                if isinstance(action, argparse._SubParsersAction)).choices[command]


def _fail(args, message, code):
    """Print the message (and, with --debug, the traceback) on stderr; return the exit code."""
    if args.debug:
        traceback.print_exc()
    print(message, file=sys.stderr)
    return code
