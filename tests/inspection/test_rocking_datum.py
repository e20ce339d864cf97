"""A tangent datum that is not unique (ISO 5459's tangent plane rocking on two points in line with its
deepest one), and the uncertainty that carries it.

On the datum block, datum A's 16 points are laid so that the plane touching them can rock about the
line of two contacts and the deepest point (11 um) without changing its largest distance. Before,
whichever of those planes the search met was taken and nothing was said; each Monte Carlo trial
took whichever its linear programme met, so that U missed the rocking (0.50 um against a brute
force's 1.38 um at u = 0.1 um). Now the least squares among the tangent planes is taken (the
constrained L2 secondary criterion), alike alone and in a frame, in the inspection and in each trial.

Checked independently: the constrained L2 plane of the aligned datum points by scipy's SLSQP written
here, and U against full re-inspections of the same trials (the Monte Carlo's own draws, put back on
the measured points), which no linear model shortens."""
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import linprog, minimize

import cmmsampling
from cmmsampling.formats.exporting import as_point_set
from cmmsampling.geometry.blocks import datum_block
from cmmsampling.inspection.align import transform

FRAME = ("Face1", "Face5", "Face4")
MISPLACED = cmmsampling.Misplacement(rx=1.0, ry=-0.5, rz=2.0, x=5.0, y=-3.0, z=1.0)
DEEPEST = 0.011


@pytest.fixture(scope="module")
def rocking():
    """(shape, plan, measured PointSet): Face1's points 2-8 um into the material but for two
    contacts and the 11 um deepest point, all three on the line x = 33.9 mm; the top waves 20 um."""
    shape = datum_block()
    plan = cmmsampling.plan(shape, n_total=80, strategy="uniform_parametric", faces=[3, 1, 5, 4], processes=1)
    nominal = as_point_set(plan)
    shift = np.random.default_rng(4).uniform(-0.008, -0.002, len(nominal))
    primary = np.flatnonzero(np.array(nominal.faces) == "Face1")
    line = primary[np.abs(nominal.points[primary, 0] - nominal.points[primary[4], 0]) < 1e-9]
    assert len(line) == 3
    shift[line] = 0.0, -DEEPEST, 0.0
    top = np.flatnonzero(np.array(nominal.faces) == "Face3")
    shift[top] = 0.02 * np.sin(nominal.points[top, 0] / 17.0)
    points = transform(MISPLACED.matrix(nominal.points.mean(axis=0)), nominal.points + shift[:, None] * nominal.normals)
    return shape, plan, replace(nominal, points=points, uv=None, deviation=None, travel=None)


def constrained_l2_tilt(points):
    """(a, b, c) of the plane z = a x + b y + c under points (M, 3) mm (all above it, every point
    z >= plane) with the least largest distance, and among those planes the one whose squared
    distances sum least: a linear programme, then SLSQP, written here."""
    rows = np.column_stack([points[:, :2], np.ones(len(points))])
    solved = linprog(np.r_[0.0, 0.0, 0.0, 1.0], A_ub=np.vstack([np.c_[rows, np.zeros(len(rows))],
                                                                  np.c_[-rows, -np.ones(len(rows))]]),
                     b_ub=np.r_[points[:, 2], -points[:, 2]], bounds=[(None, None)] * 3 + [(0, None)], method="highs")
    deepest = solved.x[3]
    gaps = lambda plane: points[:, 2] - rows @ plane  # noqa: E731
    chosen = minimize(lambda plane: gaps(plane) @ gaps(plane), solved.x[:3], method="SLSQP",
                      constraints=[{"type": "ineq", "fun": lambda plane: gaps(plane) + 1e-9},
                                   {"type": "ineq", "fun": lambda plane: deepest + 1e-9 - gaps(plane)}],
                      options={"ftol": 1e-20, "maxiter": 200})
    return chosen.x, deepest


def datum_points(measured, found, face="Face1"):
    """Datum ``face``'s measured points in the CAD frame of the inspection ``found``."""
    return transform(found.transform, measured.points[np.array(measured.faces) == face])


def test_a_rocking_datum_is_named_and_taken_alike_alone_and_in_a_frame(rocking):
    shape, plan, measured = rocking
    alone = cmmsampling.inspect(plan, measured, part=shape, datums=FRAME[:1])
    framed = cmmsampling.inspect(plan, measured, part=shape, datums=FRAME)
    np.testing.assert_allclose(alone.datums[0].deviations, framed.datums[0].deviations, atol=1e-6)
    for found in (alone, framed):
        assert found.datums[0].rocking > 0.001
        assert "A (Face1, tangent, 3 motions, 16 points, form 0.0110 mm, not unique: tangent solutions" in found.summary()
        assert not any("not unique" in fit.text() for fit in found.datums[1:])
        points = datum_points(measured, found)
        # The datum's points lie over the plane z = 0 of Face1 (outward normal -z): the plane chosen
        # is the constrained L2 plane, found here independently.
        plane, deepest = constrained_l2_tilt(points)
        assert deepest == pytest.approx(DEEPEST, abs=1e-6)
        assert np.abs(plane * [100.0, 60.0, 1.0]).max() < 2e-6     # mm over the face's 100 x 60 mm


def full_trials(plan, shape, measured, found, datums, trials):
    """(T,) mm: the profiles of full re-inspections of the Monte Carlo's first trials: its draws
    (seed 0, batches of (250, points, 3) in the links' order: the datums' points, then the
    toleranced ones) turned back into the measured frame and added to the measured points."""
    draws = np.random.default_rng(0).normal(0.0, found.uncertainty.probing, (250, len(measured.points), 3))
    faces = np.array(measured.faces)
    order = np.concatenate([np.flatnonzero(faces == face) for face in datums]
                           + [np.flatnonzero(~np.isin(faces, datums))])
    turn = found.transform[:3, :3]
    profiles = []
    for draw in draws[:trials]:
        noisy = measured.points.copy()
        noisy[order] += draw @ turn
        again = cmmsampling.inspect(plan, replace(measured, points=noisy), part=shape, datums=datums)
        profiles.append(again.profile)
    return np.array(profiles)


@pytest.mark.quality
@pytest.mark.parametrize("datums", [FRAME, ()], ids=["A|B|C, A rocking", "floating"])
@pytest.mark.parametrize("probing", [0.0001, 0.001, 0.002])
def test_the_uncertainty_is_that_of_full_reinspections(rocking, datums, probing):
    """The Monte Carlo's first 120 trials against full re-inspections of the same draws: each
    trial's profile within a tenth of U of its re-inspection's, their U within 10 %."""
    shape, plan, measured = rocking
    if not datums:
        keep = np.array(measured.faces) == "Face3"
        measured = replace(measured, labels=[label for label, kept in zip(measured.labels, keep) if kept],
                           points=measured.points[keep], normals=measured.normals[keep],
                           faces=[face for face, kept in zip(measured.faces, keep) if kept])
    found = cmmsampling.inspect(plan, measured, part=shape, datums=list(datums), uncertainty=probing)
    count = 120
    full = full_trials(plan, shape, measured, found, list(datums), count)
    linear = found.uncertainty.profiles[:count]
    spread = 2.0 * full.std(ddof=1)
    assert np.abs(linear - full).max() < 0.1 * spread
    assert 2.0 * linear.std(ddof=1) == pytest.approx(spread, rel=0.1)
