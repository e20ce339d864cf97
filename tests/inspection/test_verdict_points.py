"""How many points a verdict needs: the count found on simulated parts holds on fresh ones as
often as its quantile says, judged by inspect() itself (the part's true profile from its dense
nodes, the sampled one from the planned points), and the count before it did not."""
import pytest

import cmmsampling
from cmmsampling.formats.pointset import PointSet
from cmmsampling.geometry.validation import InputError
from cmmsampling.inspection.closest import FaceCloser
from cmmsampling.inspection.simulate import form_waves
from cmmsampling.inspection.verdict_points import dense_nodes, points_for_verdict

TOLERANCE, FORM_ERROR, SHARE = 0.05, 0.02, 0.1


def profile_on(source, points, normals, field):
    """inspect()'s minimum-zone profile of points (M, 3) mm moved along normals by field."""
    moved = points + field(points)[:, None] * normals
    return cmmsampling.inspect(source, PointSet([f"P{i}" for i in range(1, len(points) + 1)], moved, normals)).profile


@pytest.mark.quality
def test_the_count_found_holds_on_fresh_simulated_parts(reference):
    found = points_for_verdict(reference, TOLERANCE, FORM_ERROR, share=SHARE, counts=(16, 25, 36), parts=24)
    assert found.n in found.counts[1:]
    assert found.uncertainties[found.counts.index(found.n) - 1] >= SHARE * TOLERANCE, "the count before fell short"
    assert (found.gaps > -1e-6).all(), "no sample of a part is wider than the part"
    planned = cmmsampling.sample(reference, found.n, "uniform_parametric", occ_check=False)
    nominal = PointSet.from_result(planned)
    dense, normals = dense_nodes(FaceCloser(reference))
    gaps = []
    for seed in range(100, 112):
        field = form_waves(dense, FORM_ERROR, seed)
        gaps.append(profile_on(reference, dense, normals, field) - profile_on(planned, nominal.points,
                                                                             nominal.normals, field))
    assert min(gaps) > -1e-6 and sum(gap >= SHARE * TOLERANCE for gap in gaps) <= 2, gaps
    assert f"{found.n} uniform_parametric points keep the profile's sampling gap below 0.005 mm" in found.text()


def test_counts_that_cannot_make_a_verdict_are_refused_in_one_line(reference):
    with pytest.raises(InputError, match="at least 4 points"):
        points_for_verdict(reference, TOLERANCE, FORM_ERROR, counts=(3, 9))
    with pytest.raises(InputError, match="at least 20 simulated parts"):
        points_for_verdict(reference, TOLERANCE, FORM_ERROR, parts=5)
    with pytest.raises(InputError, match="form_error"):
        points_for_verdict(reference, TOLERANCE, 0.0)
