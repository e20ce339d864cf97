"""A sweep over the faces of real CAD files: every strategy at edge offsets 0 and 1 mm, each
outcome checked with OCC, not with the project's own numerics.

An outcome is "points" (every point within ON_FACE_MM of the face and inside its boundary by
OCC's face classifier, at least the offset from its edges and the spacing from the others, all by
OCC's distances), "refused" (a ValueError whose
message is one of the known refusals; "too narrow" is checked to be true: no point of a raster
over the face lies farther from the edges than the refusal says) or a failure, described.
Used by tests/package/test_sweep.py and, for docs/reliability.md, ``/usr/bin/python3 tests/support/sweep.py [FILE ...]``.
"""
import collections
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))

import cmmsampling  # noqa: E402
from cmmsampling.geometry.surface import ON_FACE_MM  # noqa: E402
from cmmsampling.geometry.freecad_env import import_part  # noqa: E402

Part = import_part()

TESTDATA = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))),
                        "shared", "testdata")
FILES = ("surf114.igs", "sunglasses_lens.igs", "hammer.iges", "Ventilator.stp")
OFFSETS = (0.0, 1.0)
POINTS = 9
QUICK = {"pso": {"iterations": 3, "population": 4}, "optimal": {"max_evaluations": 10}}
REFUSALS = {
    "too narrow": "too narrow for edge_offset",
    "footprint grid misses part": "leaves part of the face without points",
    "cannot place the points": "could not place",
    "no room at the spacing": "no room to keep",
    "no usable area": "has no usable area",
}
TOLERANCE_MM = 1e-6
RASTER = 24


def shapes():
    """{file name: Part.Shape} of the shared CAD files that are present."""
    return {name: Part.read(os.path.join(TESTDATA, name)) for name in FILES
            if os.path.isfile(os.path.join(TESTDATA, name))}


def outcome(face, strategy, offset):
    """(kind, detail) of one run: ("points", ""), ("refused", reason) or ("failure", what)."""
    try:
        result = cmmsampling.sample(face, POINTS, strategy, grid=16, edge_offset=offset, occ_check=False,
                                    workers=1, **QUICK.get(strategy, {}))
    except ValueError as refusal:
        return _refusal(face, str(refusal))
    except Exception as exc:   # every other exception is a failure of the sweep, reported
        return "failure", f"{type(exc).__name__}: {exc}"
    return _check_points(face, result, offset)


def _refusal(face, message):
    """The refusal's reason, or a failure when the message is unknown or a false 'too narrow'."""
    reason = next((name for name, words in REFUSALS.items() if words in message), None)
    if reason is None:
        return "failure", f"unknown refusal: {message}"
    if reason == "too narrow":
        farthest = float(re.search(r"farther than ([\d.e+-]+) mm", message).group(1))
        reached = _farthest_from_edges(face)
        if reached > farthest * 1.005 + 1e-9:   # the message rounds to two digits
            return "failure", f"false refusal: a point {reached:.4g} mm from the edges; {message}"
    return "refused", reason


def _farthest_from_edges(face):
    """The largest OCC distance from the edges of the face's points on a RASTER x RASTER grid of
    its parameter range (those on the face: within ON_FACE_MM and inside by OCC's classifier), mm."""
    u0, u1, v0, v1 = face.ParameterRange
    edges = Part.Compound(face.Edges)
    farthest = 0.0
    for u in np.linspace(u0, u1, RASTER):
        for v in np.linspace(v0, v1, RASTER):
            vertex = Part.Vertex(face.valueAt(u, v))
            if face.isPartOfDomain(u, v) and face.distToShape(vertex)[0] <= ON_FACE_MM:
                farthest = max(farthest, edges.distToShape(vertex)[0])
    return farthest


def _check_points(face, result, offset):
    """("points", "") when the result's points are on the face, off its edges and spaced (OCC)."""
    vertices = [Part.Vertex(*p) for p in result.points]
    off = max(face.distToShape(v)[0] for v in vertices)
    if off > result.model.tolerance:
        return "failure", f"a point {off:.3g} mm off the face"
    outside = sum(not result.model.face.isPartOfDomain(u, v) for u, v in result.uv)
    if outside:
        return "failure", f"{outside} point(s) outside the face's boundary by OCC's classifier"
    if offset > 0:
        edges = Part.Compound(face.Edges)
        clearance = min(edges.distToShape(v)[0] for v in vertices)
        if clearance < offset - TOLERANCE_MM:
            return "failure", f"a point {clearance:.4g} mm from the edges (offset {offset:g} mm)"
    gaps = np.linalg.norm(result.points[:, None] - result.points[None], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    if gaps.min() < result.settings["min_spacing"] - TOLERANCE_MM:
        return "failure", f"two points {gaps.min():.4g} mm apart (spacing {result.settings['min_spacing']:.4g} mm)"
    return "points", ""


def table(counts):
    """Markdown table of {file: Counter of (kind, detail)}: faces' runs by outcome."""
    reasons = list(REFUSALS)
    head = ("| file | runs | points | " + " | ".join(f"refused: {r}" for r in reasons) + " | failures |")
    lines = [head, "|" + " --- |" * (len(reasons) + 4)]
    for name, counter in counts.items():
        runs = sum(counter.values())
        failures = sum(v for (kind, _), v in counter.items() if kind == "failure")
        cells = [str(counter[("refused", r)]) for r in reasons]
        lines.append(f"| {name} | {runs} | {counter[('points', '')]} | " + " | ".join(cells) + f" | {failures} |")
    return "\n".join(lines)


def main(names=()):
    """Sweep every face of the shared files named (default: all); print failures as they come
    and the table."""
    counts = collections.OrderedDict()
    for name, shape in shapes().items():
        if names and name not in names:
            continue
        counter = counts.setdefault(name, collections.Counter())
        for number, face in enumerate(shape.Faces, start=1):
            print(f"{name} Face{number}", file=sys.stderr, flush=True)
            for strategy in cmmsampling.self_contained():
                for offset in OFFSETS:
                    kind, detail = outcome(face, strategy, offset)
                    counter[(kind, detail)] += 1
                    if kind == "failure":
                        print(f"{name} Face{number} {strategy} offset {offset:g}: {detail}", flush=True)
        print(f"{name}: {len(shape.Faces)} faces done", file=sys.stderr, flush=True)
    print(table(counts))


if __name__ == "__main__":
    main(sys.argv[1:])
