"""NIST's four PMI test models from their QIF MBD files to a verdict per characteristic: read_mbd
-> plan -> the simulated CMM over I++ DME -> inspect, with a known form error on every face
but the datums' and the part misplaced on the table. Each judged characteristic's value must
be what an independent minimum-zone fit of the same error finds (a linear programme over the
motions the characteristic's zone may take: all for a form, those its datums leave free for a
profile, those plus every shift for an orientation), and its verdict must follow."""
import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import cKDTree

import cmmsampling
from cmmsampling.cmm.server import VirtualPart
from cmmsampling.inspection.simulate import Misplacement
from support.mbd import MODELS, shared_mbd

pytestmark = pytest.mark.once

# The error's wavelength, mm, and its amplitude on each face as a share of the face's tolerance:
# faces take these shares in turn, so that some characteristics pass and others fail.
WAVELENGTH_MM = 40.0
SHARES = (0.15, 0.9)
MISPLACED = Misplacement(x=0.4, y=-0.25, z=0.1, rx=0.05, ry=-0.04, rz=0.12)
# The value found against the independent fit, mm: the alignment's iterations stop within this.
AGREEMENT_MM = 2e-4


def known_errors(mbd_plan):
    """{face name: amplitude mm} for every planned face that is no datum face, and the form
    error at points (M, 3) on those faces (0 on the datum faces)."""
    datum_faces = {name for faces in mbd_plan.datum_faces.values() for name in faces}
    tolerances = mbd_plan.face_tolerances
    names = [name for name in tolerances if name not in datum_faces]
    return {name: SHARES[k % len(SHARES)] * tolerances[name] for k, name in enumerate(names)}


def field_of(points_set, amplitudes):
    """(M,) mm the error at each planned point: a wave across its face, amplitude by face."""
    points = points_set.points
    amplitude = np.array([amplitudes.get(face, 0.0) for face in points_set.faces])
    phase = np.array([hash_phase(face) for face in points_set.faces])
    wave = np.sin(2 * np.pi * points @ np.array([0.6, 0.8, 0.0]) / WAVELENGTH_MM + phase)
    wave *= np.cos(2 * np.pi * points[:, 2] / WAVELENGTH_MM)
    return amplitude * wave


def hash_phase(face):
    """A phase (rad) that differs between faces, from the face's number."""
    return 0.7 * int(face[4:])


def twists_at(points, normals, pivot):
    """(M, 6) the change of the signed distances per twist (rotation vector rad about pivot,
    then the shift mm)."""
    return np.hstack([np.cross(points - pivot, normals), normals])


def face_samples(face, count=24):
    """(points (K, 3), outward normals (K, 3)) on a face: a grid over its parameters, inside it."""
    u0, u1, v0, v1 = face.ParameterRange
    points, normals = [], []
    for u in np.linspace(u0, u1, count):
        for v in np.linspace(v0, v1, count):
            if face.isPartOfDomain(u, v):
                p, n = face.valueAt(u, v), face.normalAt(u, v)
                points.append([p.x, p.y, p.z])
                normals.append([n.x, n.y, n.z])
    return np.array(points), np.array(normals)


def allowed_twists(c, mbd_plan, pivot):
    """(6, K) the motions c's zone may take: every one for a form or a profile without datums;
    the null space of its datum faces' distances (perfect datums stay on their faces) for a
    profile; with every shift added for an orientation."""
    if c.kind == "Flatness" or not c.datums:
        return np.eye(6)
    rows = []
    for label in c.datums:
        for name in mbd_plan.datum_faces[label]:
            points, normals = face_samples(mbd_plan.model.shape.getElement(name))
            rows.append(twists_at(points, normals, pivot))
    stacked = np.vstack(rows)
    scale = np.r_[np.full(3, 100.0), np.ones(3)]
    _, weights, vt = np.linalg.svd(stacked * scale, full_matrices=False)
    free = (vt[weights < 1e-6 * weights[0]].T * scale[:, None])
    if c.kind in ("Perpendicularity", "Parallelism", "Angularity"):
        free = np.hstack([free, np.vstack([np.zeros((3, 3)), np.eye(3)])])
    return free


def expected_value(c, mbd_plan, planned, errors):
    """2 min over the allowed motions of max |e + J t| over c's planned points (a linear
    programme): the zone's width the characteristic's value must be."""
    rows = np.isin(planned.faces, c.faces)
    points, normals = planned.points[rows], planned.normals[rows]
    pivot = points.mean(axis=0)
    basis = allowed_twists(c, mbd_plan, pivot)
    jacobian = twists_at(points, normals, pivot) @ basis
    k = jacobian.shape[1]
    cost = np.r_[np.zeros(k), 1.0]
    upper = np.vstack([np.hstack([jacobian, -np.ones((len(points), 1))]),
                       np.hstack([-jacobian, -np.ones((len(points), 1))])])
    bound = np.r_[-errors[rows], errors[rows]]
    found = linprog(cost, A_ub=upper, b_ub=bound, bounds=[(None, None)] * k + [(0, None)], method="highs")
    assert found.success, found.message
    return 2.0 * found.x[-1]


@pytest.mark.parametrize("model", MODELS)
def test_each_characteristic_is_judged_as_an_independent_fit_finds(model, tmp_path):
    mbd = cmmsampling.read_mbd(shared_mbd(model + ".qif"))
    mbd_plan = cmmsampling.plan(mbd, strategy="hammersley", n_max=25)
    planned = mbd_plan.point_set()
    assert planned.metadata["mbd"] == mbd.path
    frame_faces = {name for names in mbd_plan.program_frame.values() for name in names}
    first = [face in frame_faces for face in planned.faces]
    assert frame_faces and first == sorted(first, reverse=True), "the program frame's datum points come first"
    amplitudes = known_errors(mbd_plan)
    errors = field_of(planned, amplitudes)
    tree = cKDTree(planned.points)

    def form(points):
        return errors[tree.query(points)[1]]

    part = VirtualPart(form, MISPLACED.matrix(planned.points.mean(axis=0)))
    with cmmsampling.SimulatedCMM(part) as cmm:
        run = cmmsampling.measure(mbd_plan, cmm.address, out=tmp_path / "measured.csv")
    uncertainty = 0.002 if model == MODELS[0] else None
    found = cmmsampling.inspect(mbd_plan, run, uncertainty=uncertainty)

    judged = {c.id for c in mbd.judged()}
    assert {r.id for r in found.characteristics} | {c.id for c, _ in mbd_plan.unplanned} == judged
    verdicts = set()
    for result in found.characteristics:
        expected = expected_value(result.characteristic, mbd_plan, planned, errors)
        assert result.value == pytest.approx(expected, abs=AGREEMENT_MM), (result.id, result.kind)
        assert result.passed == (expected <= result.tolerance), result.id
        verdicts.add(result.passed)
        if uncertainty is not None:
            assert result.uncertainty > 0
            assert result.decision == ("conforms" if result.value + result.uncertainty <= result.tolerance else
                                       "does not conform" if result.value - result.uncertainty > result.tolerance
                                       else "undecided")
    assert found.passed is (False if False in verdicts else True)
    check_results_files(found, mbd, tmp_path)


def check_results_files(found, mbd, folder):
    """The QIF results (schema-valid, the model's own ids, read back to the values) and the
    first-article table as CSV and HTML (every characteristic of the model, judged or not)."""
    import csv

    from cmmsampling.formats.qif.mbd_results import read_mbd_results
    from cmmsampling.formats.qif.schema import schema_errors

    report = cmmsampling.export(found, folder / "results.qif")
    text = (folder / "results.qif").read_text()
    assert report.passed is found.passed and not schema_errors(text)
    back = read_mbd_results(str(folder / "results.qif"))
    assert set(back) == {result.id for result in found.characteristics}
    for result in found.characteristics:
        status, value = back[result.id]
        assert value == pytest.approx(result.value, rel=1e-12, abs=1e-15)
        assert status == {"conforms": "PASS", "does not conform": "FAIL", "undecided": "INDETERMINATE",
                          None: "PASS" if result.passed else "FAIL"}[result.decision]
    written = cmmsampling.read_mbd(str(folder / "results.qif"))
    assert [c.id for c in written.characteristics] == [c.id for c in mbd.characteristics]
    found.write_csv(folder / "first_article.csv")
    with open(folder / "first_article.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["Characteristic"] for row in rows[:len(found.characteristics)]] == [r.id for r in found.characteristics]
    assert {row["Characteristic"] for row in rows} == {c.id for c in mbd.characteristics}
    assert all(row["Conforms"] == "not judged" and row["Decision"] for row in rows[len(found.characteristics):])
    page = found.write_html(folder / "first_article.html")
    assert all(f"<td>{c.id}</td>" in open(page).read() for c in mbd.characteristics)
