"""The profile's uncertainty by Monte Carlo and ISO 14253-1's decision.

On a plane the Monte Carlo meets the closed-form propagation (GUM's law, the profile's
sensitivity to each point through the least-squares fit); on a curved face with datums each
trial of the Monte Carlo (solved on the linear model) is what a full inspection of the same
perturbed points finds."""
import re
from dataclasses import replace

import numpy as np
import pytest
from support.faces import Part

import cmmsampling
import cmmsampling.inspection.judge
from cmmsampling.geometry.blocks import datum_block
from cmmsampling.formats.exporting import as_point_set
from cmmsampling.formats.pointset import PointSet
from cmmsampling.inspection.align import transform
from cmmsampling.inspection.uncertainty import BATCH, SAMPLING_ERROR, decide

FRAME = ("Face1", "Face5", "Face4")
MISPLACED = cmmsampling.Misplacement(rx=1.0, ry=-0.5, rz=2.0, x=5.0, y=-3.0, z=1.0)


def plane_points(bump):
    """3 x 3 contact points on a 30 mm square of the plane z = 0, the corner one raised by bump mm."""
    x, y = np.meshgrid([0.0, 15.0, 30.0], [0.0, 15.0, 30.0], indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(9)])
    points[0, 2] = bump
    return PointSet([f"P{index}" for index in range(1, 10)], points, np.tile([0.0, 0.0, 1.0], (9, 1)))


@pytest.mark.parametrize("alignment", ["best_fit", "none"])
def test_on_a_plane_the_monte_carlo_meets_the_closed_form(alignment):
    probing = 0.001
    found = cmmsampling.inspect(Part.makePlane(30, 30), plane_points(0.05), alignment, uncertainty=probing)
    design = np.column_stack([np.ones(9), plane_points(0.0).points[:, :2]])
    leverage = (design @ np.linalg.solve(design.T @ design, design.T))[0, 0] if alignment == "best_fit" else 0.0
    closed = 2.0 * 2.0 * probing * np.sqrt(1.0 - leverage)
    assert found.uncertainty.relative_error <= SAMPLING_ERROR
    assert found.profile_uncertainty == pytest.approx(closed, rel=3 * SAMPLING_ERROR)
    if alignment == "best_fit":
        assert abs(found.profile_uncertainty - 4 * probing) > 3 * SAMPLING_ERROR * closed


@pytest.fixture(scope="module")
def block():
    """(shape, plan, nominal PointSet) of the datum tests' block: 16 points a face."""
    shape = datum_block()
    plan = cmmsampling.plan(shape, n_total=80, strategy="uniform_parametric", faces=[3, 1, 5, 4], processes=1)
    return shape, plan, as_point_set(plan)


def shifted(nominal, shift):
    """The nominal points as read on the misplaced block, its top (Face3) moved out by shift mm."""
    along = np.array([shift if face == "Face3" else 0.0 for face in nominal.faces])
    matrix = MISPLACED.matrix(nominal.points.mean(axis=0))
    return replace(nominal, points=transform(matrix, nominal.points + along[:, None] * nominal.normals), uv=None,
                   deviation=None, travel=None)


def test_each_trial_is_what_a_full_inspection_of_its_points_finds(block):
    shape, plan, nominal = block
    read = shifted(nominal, 0.02)
    found = cmmsampling.inspect(plan, read, part=shape, datums=FRAME, uncertainty=0.002, seed=5)
    order = [[face == name for face in read.faces] for name in FRAME + ("Face3",)]
    rows = np.concatenate([np.flatnonzero(mask) for mask in order])
    noise = np.random.default_rng(5).normal(0.0, 0.002, size=(BATCH, len(rows), 3))
    turn = found.transform[:3, :3]
    for trial in range(4):
        moved = read.points.copy()
        moved[rows] += noise[trial] @ turn
        again = cmmsampling.inspect(plan, replace(read, points=moved), part=shape, datums=FRAME)
        assert again.profile == pytest.approx(found.uncertainty.profiles[trial], abs=1e-5)


@pytest.mark.parametrize("shift, decision", [(0.01, "conforms"), (0.024, "undecided"), (0.04, "does not conform")])
def test_the_decision_keeps_the_uncertainty_as_a_guard_band(block, shift, decision):
    shape, plan, nominal = block
    found = cmmsampling.inspect(plan, shifted(nominal, shift), part=shape, tolerance=0.05, datums=FRAME,
                                uncertainty=0.002)
    assert found.decision == decision == decide(found.profile, found.profile_uncertainty, 0.05)
    assert 0.003 < found.profile_uncertainty < 0.01
    assert f"ISO 14253-1: {decision} (profile {found.profile:.4f} mm" in found.summary()


def test_without_an_uncertainty_the_verdict_says_none_was_given(block):
    shape, plan, nominal = block
    found = cmmsampling.inspect(plan, shifted(nominal, 0.024), part=shape, tolerance=0.05, datums=FRAME)
    assert found.passed and found.decision is None and found.profile_uncertainty is None
    assert "no uncertainty given" in found.summary()


def test_the_monte_carlo_is_seeded(block):
    shape, plan, nominal = block
    runs = [cmmsampling.inspect(plan, shifted(nominal, 0.02), part=shape, datums=FRAME, uncertainty=0.002, seed=seed)
            for seed in (0, 0, 1)]
    assert runs[0].profile_uncertainty == runs[1].profile_uncertainty != runs[2].profile_uncertainty
    assert runs[2].profile_uncertainty == pytest.approx(runs[0].profile_uncertainty, rel=3 * SAMPLING_ERROR)


def test_decide_follows_iso_14253_1():
    assert decide(0.039, 0.010, 0.05) == "conforms"
    assert decide(0.041, 0.010, 0.05) == "undecided"
    assert decide(0.059, 0.010, 0.05) == "undecided"
    assert decide(0.061, 0.010, 0.05) == "does not conform"


def test_the_monte_carlo_reports_its_trials_and_stops_on_cancel(block):
    from cmmsampling.inspection.judge import InspectionCancelled

    shape, plan, nominal = block
    said = []

    def progress(message):
        said.append(message)
        return message is not None and message.endswith(": 50 trials")

    with pytest.raises(InspectionCancelled):
        cmmsampling.inspect(plan, shifted(nominal, 0.02), part=shape, datums=FRAME, uncertainty=0.002,
                            progress=progress)
    trials = [message for message in said if message and "Monte Carlo" in message]
    assert trials == [f"propagating the probing uncertainty (Monte Carlo): {count} trials" for count in (0, 25, 50)]


@pytest.mark.quality
def test_where_the_linear_model_fails_u_is_that_of_full_reinspections():
    """A 2 mm ball probed with u = 0.6 mm: the linear model's trials miss full re-inspections by
    about U, so U is that of 200 full re-inspections, and the summary says so with their time; at
    u = 0.3 mm the first trials meet theirs to a tenth of U and the text says how closely."""
    face = Part.makeSphere(2.0).Faces[0]
    uv = np.random.default_rng(2).uniform([0.3, -1.0], [6.0, 1.0], (30, 2))
    points = np.array([tuple(face.Surface.value(u, v)) for u, v in uv])
    labels = [f"P{index}" for index in range(1, len(points) + 1)]
    measured = PointSet(labels, points, np.full_like(points, np.nan))
    planned = cmmsampling.inspection.judge.Planned(labels, points, [face], ["ball"], np.zeros(len(points), dtype=int))
    rough = cmmsampling.inspect(planned, measured, alignment="best_fit", uncertainty=0.6)
    assert rough.uncertainty.full and rough.uncertainty.trials == 200
    assert rough.uncertainty.checked > 0.1 * rough.profile_uncertainty
    assert re.search(r"U is that of 200 full re-inspections \(\d+ s\)", rough.summary())
    fine = cmmsampling.inspect(planned, measured, alignment="best_fit", uncertainty=0.3)
    assert not fine.uncertainty.full and fine.uncertainty.checked < 0.1 * fine.profile_uncertainty
    assert "3 of them met full re-inspections to" in fine.summary()
