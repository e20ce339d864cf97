"""Moving points onto the feasible part of a trimmed face (cmmsampling.geometry.domain)."""
import numpy as np
import pytest
from support.faces import holed_face

from cmmsampling.geometry.domain import face_domain
from cmmsampling.geometry.surface import SurfaceModel


@pytest.mark.parametrize("u", [0.30, 0.365, 0.44])
def test_clamping_moves_a_point_just_over_the_border_only_as_far_as_it_went(u):
    """Lines of points running from the plate into its hole (which spans u 0.26-0.47 and v
    0.45-0.68), one straight through the middle and two across slanted parts of its border. Every
    clamped point is feasible and those already feasible stay put. A point that went over the
    border by less than a cell moves back no farther than it went (its distance along the line to
    the last feasible point): a descent's line search that crosses the border meets a kink, not a
    jump. Moving to the nearest cell's centre instead moves such points about half a cell."""
    model = SurfaceModel.from_face(holed_face())
    domain = face_domain(model)
    line = np.column_stack([np.full(4001, u), np.linspace(0.75, 0.5675, 4001)])
    feasible = domain.contains(line)
    last = np.flatnonzero(~feasible)[0] - 1
    assert feasible[:last + 1].all() and not feasible[last + 1:].any()
    clamped = domain.clamp(line)
    assert domain.contains(clamped).all()
    np.testing.assert_array_equal(clamped[feasible], line[feasible])
    cell = 1.0 / domain.shape[1]
    went = line[last, 1] - line[:, 1]
    over = (went > 0) & (went < cell)
    moved = np.linalg.norm(clamped - line, axis=1)
    assert over.sum() > 10 and np.all(moved[over] <= went[over] * (1 + 1e-6) + 1e-12)
    centred = np.linalg.norm(domain.project(line) - line, axis=1)
    assert np.median(centred[over]) > 0.3 * cell
