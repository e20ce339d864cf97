"""The default spacing keeps points a ball can tell apart: at least 0.1 mm wherever the face has
room for N points that far apart, and a note where it had to go lower. On the 2 mm Ventilator blade
(Face61, 81 points) a tenth of the even spacing was 0.078 mm, and the panel's PSO put two points
0.083 mm apart: a 2 mm ball measures such a pair at one spot."""
import os

import pytest
from scipy.spatial.distance import pdist
from support.faces import TESTDATA, Part

import cmmsampling
from cmmsampling.strategies.settings import BALL_SEPARATION_MM, default_min_spacing


def test_the_default_is_a_tenth_of_the_even_spacing_but_not_below_a_ball_s_separation():
    assert default_min_spacing(10000.0, 100) == pytest.approx(1.0)
    assert default_min_spacing(49.8, 81) == BALL_SEPARATION_MM
    assert default_min_spacing(49.8, 3000, 49.8) == pytest.approx(0.5 * (49.8 / (0.75 ** 0.5 * 3000)) ** 0.5)


@pytest.mark.skipif(not os.path.isdir(TESTDATA), reason="the shared CAD files are not beside the checkout")
@pytest.mark.parametrize("strategy, options", [("pso", {"iterations": 200}), ("random", {})])
def test_points_on_a_2_mm_blade_keep_a_ball_s_separation(strategy, options):
    face = Part.read(os.path.join(TESTDATA, "Ventilator.stp")).getElement("Face61")
    result = cmmsampling.sample(face, 81, strategy, occ_check=False, **options)
    assert result.settings["min_spacing"] == BALL_SEPARATION_MM
    assert pdist(result.points).min() >= BALL_SEPARATION_MM - 1e-9
    assert not [note for note in result.notes if "no room" in note]


def test_a_face_without_room_says_how_near_its_points_are():
    """1000 points on a 4 x 4 mm plate: 0.1 mm apart would need more room than hexagonal packing
    leaves, so they keep less and the result says so."""
    face = Part.makePlane(4, 4).Faces[0]
    result = cmmsampling.sample(face, 1000, "halton", occ_check=False)
    spacing = result.settings["min_spacing"]
    assert spacing < BALL_SEPARATION_MM and pdist(result.points).min() >= spacing - 1e-9
    [note] = [note for note in result.notes if "no room" in note]
    assert note.startswith(f"the face has no room for 1000 points 0.1 mm apart: they keep {spacing:.3g} mm")
