"""Every strategy at edge offsets 0 and 1 mm on faces of the shared CAD files, checked with OCC
(tests/support/sweep.py): points on the face, off its edges and spaced, or a true, known refusal.

The default run takes a deterministic subset (the small files' faces and the Ventilator's faces
that once put points off the face, were refused falsely or, Face296, ran out of memory);
``-m slow`` takes every face."""
import os

import pytest
from support import sweep

SUBSET = {
    "surf114.igs": (1, 3),
    "sunglasses_lens.igs": (5,),
    "hammer.iges": (4,),
    "Ventilator.stp": (19, 123, 236, 240, 296),
}
SHAPES = sweep.shapes() if os.path.isdir(sweep.TESTDATA) else {}


def every_face():
    """(file, face number) of every face of every shared file present."""
    return [(name, number) for name, shape in SHAPES.items() for number in range(1, len(shape.Faces) + 1)]


def check_face(name, number):
    face = SHAPES[name].Faces[number - 1]
    failures = []
    for strategy in sweep.cmmsampling.self_contained():
        for offset in sweep.OFFSETS:
            kind, detail = sweep.outcome(face, strategy, offset)
            if kind == "failure":
                failures.append(f"{strategy} offset {offset:g}: {detail}")
    assert not failures, f"{name} Face{number}: " + "; ".join(failures)


needs_files = pytest.mark.skipif(not SHAPES, reason="shared test data folder absent")


@needs_files
@pytest.mark.parametrize("name, number", [(n, k) for n, ks in SUBSET.items() for k in ks])
def test_a_subset_of_real_faces_gives_checked_points_or_true_refusals(name, number):
    if name not in SHAPES:
        pytest.skip(f"{name} absent")
    check_face(name, number)


@pytest.mark.slow
@needs_files
@pytest.mark.parametrize("name, number", every_face())
def test_every_real_face_gives_checked_points_or_true_refusals(name, number):
    check_face(name, number)
