"""Defaults that work on the first face a user picks: an edge offset that adapts to the face
(capped at a probe's), and optimisers that do not run where no point set can do better."""
import numpy as np
import pytest
from support.faces import Part, strip_face

import cmmsampling
from cmmsampling.cli import main as cli_main
from cmmsampling.gui.handover import handed
from cmmsampling.strategies import sampling
from cmmsampling.strategies.estimates import JUDGINGS, duration_text, sharing_processes, time_left_text
from cmmsampling.strategies.sampling import PROBE_EDGE_OFFSET_MM


def edge_distances(face, points):
    """OCC's distance (mm) of each point to the face's edges."""
    edges = Part.Compound(face.Edges)
    return np.array([edges.distToShape(Part.Vertex(*p))[0] for p in points])


def test_a_wide_face_gets_the_probes_edge_offset():
    assert cmmsampling.probe_edge_offset(cmmsampling.reference_face()) == PROBE_EDGE_OFFSET_MM
    assert cmmsampling.probe_edge_offset(cmmsampling.reference_face(), cap=3.0) == 3.0
    assert cmmsampling.probe_edge_offset(cmmsampling.reference_face(), cap=0) == 0.0


def test_a_2_mm_strip_gets_an_offset_that_fits_and_samples_with_it():
    face = strip_face().Faces[0]
    offset = cmmsampling.probe_edge_offset(face)
    assert 0.2 < offset < 0.6, offset
    result = cmmsampling.sample(face, 25, "halton", edge_offset=offset)
    assert edge_distances(face, result.points).min() >= offset - 1e-6


def test_the_command_line_adapts_the_edge_offset_to_a_strip(tmp_path, capsys):
    path = str(tmp_path / "strip.step")
    strip_face().exportStep(path)
    out = str(tmp_path / "strip.csv")
    assert cli_main(["sample", path, "--face", "1", "-n", "16", "--strategy", "halton", "--out", out]) == 0
    printed = capsys.readouterr().out
    offset = cmmsampling.probe_edge_offset(Part.read(path).Faces[0])
    assert f"edge offset {offset:g} mm (default for this face)" in printed


def test_an_optimiser_on_a_plane_returns_at_once_and_says_why():
    plane = Part.makePlane(50, 30).Faces[0]
    result = cmmsampling.sample(plane, 25, "pso", iterations=3000)
    assert result.exact and result.evaluations == 0
    assert any("pso was not run" in note for note in result.notes), result.notes
    uniform = cmmsampling.sample(plane, 25, "uniform_parametric")
    np.testing.assert_allclose(result.uv, uniform.uv)


def test_an_optimiser_on_a_curved_face_still_runs():
    result = cmmsampling.sample(cmmsampling.reference_face(), 16, "pso", iterations=3, population=4)
    assert result.evaluations > 0 and not any("was not run" in note for note in result.notes)


def test_a_handed_over_run_is_returned_once_for_exactly_its_call():
    """The console's echo of a panel's run (cmmsampling.gui.handover, pure Python) binds the run
    made in the worker thread, once; the engine itself keeps no state."""
    face = cmmsampling.reference_face()
    arguments = {"n": 16, "strategy": "halton", "edge_offset": 1.5, "grid": 20}
    made = cmmsampling.sample(face, **arguments)
    real = cmmsampling.sample
    with handed("sample", face, arguments, made):
        assert cmmsampling.sample(face, 16, "halton", edge_offset=1.5, grid=20) is made
        again = cmmsampling.sample(face, **arguments)
    assert cmmsampling.sample is real and again is not made
    np.testing.assert_array_equal(again.uv, made.uv)
    assert sampling.sample(face, **arguments) is not made


def test_a_handed_over_run_is_not_taken_by_another_call_or_face():
    face = cmmsampling.reference_face()
    made = cmmsampling.sample(face, 16, "halton")
    with handed("sample", face, {"n": 16, "strategy": "halton"}, made):
        assert cmmsampling.sample(face, 16, "hammersley") is not made
        assert cmmsampling.sample(cmmsampling.reference_face(), 16, "halton") is not made
        assert cmmsampling.sample(face, 16, "halton") is made
    assert cmmsampling.sample(face, 16, "halton") is not made


def test_the_time_estimate_follows_the_strategys_steps():
    face = cmmsampling.reference_face()
    short = cmmsampling.time_needed(face, 25, "pso", iterations=10, workers=1)
    long = cmmsampling.time_needed(face, 25, "pso", iterations=10000, workers=1)
    assert 0 < short < long
    assert cmmsampling.time_needed(face, 25, "optimal") is None
    assert cmmsampling.time_needed(face, 25, "optimal", time_limit=30.0) >= 30.0
    with pytest.raises(ValueError, match="inertia must decrease"):
        cmmsampling.time_needed(face, 25, "pso", w1=0.1, w2=0.5)


def test_the_time_estimate_counts_a_second_process_only_where_a_core_is_free():
    """A 2-core desktop beside one CPU-bound process: the split would not pay, the default keeps
    the swarm in one process, and the estimate must not halve the steps (it read 5x low)."""
    assert sharing_processes(2, load=0.3, cores=2) == 2
    assert sharing_processes(2, load=1.0, cores=2) == 1
    assert sharing_processes(2, load=1.0, cores=4) == 2
    assert sharing_processes(1, load=0.0, cores=8) == 1


def test_the_time_estimate_counts_the_judging_of_an_optimisers_result():
    """An optimiser's result is judged exactly (its best and the uniform layouts it started
    from): time the estimate counts even where the optimiser itself has none."""
    face = cmmsampling.reference_face()
    estimate = cmmsampling.time_needed(face, 25, "optimal", time_limit=0.001)
    judged_s = cmmsampling.sample(face, 25, "uniform_parametric", occ_check=False).timings["evaluation_s"]
    assert estimate >= 0.5 * JUDGINGS * judged_s > 0


@pytest.mark.parametrize("seconds, words, left", [
    (0.4, "under a second", "under a second left"), (1.2, "1 s", "about 1 s left"),
    (119.4, "119 s", "about 119 s left"), (150, "2 min", "about 2 min left"),
    (3569, "59 min", "about 59 min left"), (3571, "1 h 0 min", "about 1 h 0 min left"),
    (3900, "1 h 5 min", "about 1 h 5 min left"),
])
def test_durations_read_the_same_in_every_progress_line(seconds, words, left):
    """One wording of a duration for the panels' estimates, a run's and a plan's time left and the
    demo's time: seconds below 2 min, minutes below an hour, then hours and minutes."""
    assert (duration_text(seconds), time_left_text(seconds)) == (words, left)


def test_more_poles_than_points_is_said():
    face = cmmsampling.reference_face()
    result = cmmsampling.sample(face, 25, "halton", fit_poles=40, grid=20)
    assert any("40 x 40 poles for 25 points" in note and "default for 25 points is 4 x 4" in note
               for note in result.notes), result.notes
    assert not any("poles for" in note for note in cmmsampling.sample(face, 25, "halton").notes)
