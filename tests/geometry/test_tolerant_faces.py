"""A tolerant face sampled as OCC accepts it: OCCT's Top.brep Face66 (a trimmed degree-8 B-spline
face whose own tolerance is 0.012 mm; valid by isValid and check) has a band between its curves on
the surface and its 3D edges where points are inside the curves but 0.01-0.02 mm off the face by
OCC's distance and outside its classifier. Every strategy's points end within 1e-4 mm of the face
by distToShape and inside it by ``isInside(p, 1e-4, True)``, checked here with OCC directly.
Skipped without the shared test data."""
import os

import numpy as np
import pytest
from support.faces import TESTDATA, FreeCAD, Part

import cmmsampling

TOP = os.path.join(TESTDATA, "Top.brep")
# Quick settings of the searching strategies: the placement on the face is what is checked.
QUICK = {"optimal": {"time_limit": 5.0}, "pso": {"iterations": 150}}


@pytest.fixture(scope="module")
def top_face():
    if not os.path.isfile(TOP):
        pytest.skip("the shared test data (Top.brep) is not here")
    face = Part.read(TOP).Faces[65]
    assert face.isValid() and face.Tolerance > 0.01 and face.Surface.UDegree == 8
    return face


@pytest.mark.parametrize("n", [49, 81])
@pytest.mark.parametrize("strategy", ["uniform_parametric", "halton", "pso", "optimal"])
def test_every_strategy_places_its_points_on_the_tolerant_face(top_face, strategy, n):
    result = cmmsampling.sample(top_face, n, strategy, **QUICK.get(strategy, {}))
    assert result.n == n
    off = np.array([top_face.distToShape(Part.Vertex(*point))[0] for point in result.points])
    inside = [top_face.isInside(FreeCAD.Vector(*point), 1e-4, True) for point in result.points]
    assert off.max() <= 1e-4, f"{int((off > 1e-4).sum())} points up to {off.max():.4g} mm off the face"
    assert all(inside), f"{inside.count(False)} points outside the face by OCC's classifier"
    moved = [note for note in result.notes if "moved onto it" in note]
    print(f"{strategy} N = {n}: max {result.deviation.maximum:.5f} mm, farthest point {off.max():.2g} mm; {moved}")
