"""The scripting API: the paper's result on the reference surface, OCC cross-check, bad input."""
import math

import numpy as np
import pytest
from support.faces import Part

import cmmsampling
from cmmsampling.strategies.pso import SIGNIFICANT_MM


@pytest.fixture(scope="module")
def paper_runs():
    """Uniform parametric, uniform Cartesian and the paper's PSO (81 points, 25 x 3000) on the reference."""
    face = cmmsampling.reference_face()
    return {name: cmmsampling.sample(face, 81, name)
            for name in ("uniform_parametric", "uniform_cartesian", "pso")}


@pytest.mark.quality
def test_pso_with_the_paper_parameters_is_never_worse_than_its_uniform_starts(paper_runs):
    """What the method guarantees on any processor: the swarm starts from both uniform layouts and
    its best is judged against them by the exact deviation, so the result is never worse than
    either; the swarm's own best only falls, one figure an iteration."""
    pso = paper_runs["pso"].deviation.maximum
    assert pso <= paper_runs["uniform_parametric"].deviation.maximum + SIGNIFICANT_MM
    assert pso <= paper_runs["uniform_cartesian"].deviation.maximum + SIGNIFICANT_MM
    history = paper_runs["pso"].history
    assert len(history) == 3000 and np.all(np.diff(history) <= 0)
    assert paper_runs["pso"].evaluations == 25 * 3001


# The paper's run over 12 seeds (benchmarks/paper_run_spread.py, docs/benchmarks/paper-run-spread.md;
# numpy 1.24 on an AMD EPYC): median 0.6627 mm, lowest 0.6427 mm, highest 0.9091 mm (seed 11), uniform
# parametric 0.9872 mm. Another processor's rounding sends the swarm along another path, as another
# seed does: seed 0 gave 0.6457 mm on that AMD EPYC and 0.6538 mm on an Intel Xeon.
SEED_SPREAD = (0.6427, 0.9091)


@pytest.mark.quality
def test_speed_ups_kept_the_paper_run_result(paper_runs):
    """The best maximum of the paper's run (seed 0) on the delivered substitute lies within the
    spread the seeds show, widened by 5 % (the swarm's path follows the last digits of its
    single-precision fitness, which another processor or numpy rounds differently, so no figure
    tighter than the seeds' spread holds on every machine); bit-identity between one and two
    processes is in test_parallel."""
    best = paper_runs["pso"].deviation.maximum
    assert 0.95 * SEED_SPREAD[0] <= best <= 1.05 * SEED_SPREAD[1]


@pytest.mark.quality
def test_uniform_figures_are_geometric(paper_runs):
    """The two-sided maxima of the uniform layouts on the delivered substitute (0.9796 and 0.9234 mm
    from the feet of a reference fit to the extended substitute before issue 31; 0.9848 mm at the
    nodes alone, before the peaks between them were searched)."""
    assert paper_runs["uniform_parametric"].deviation.maximum == pytest.approx(0.98716, abs=1e-4)
    assert paper_runs["uniform_cartesian"].deviation.maximum == pytest.approx(
        paper_runs["uniform_cartesian"].deviation.occ_maximum, rel=1e-6)


@pytest.mark.quality
@pytest.mark.parametrize("name", ["uniform_parametric", "uniform_cartesian", "pso"])
def test_occ_cross_check(paper_runs, name):
    d = paper_runs[name].deviation
    assert d.occ_maximum == pytest.approx(d.maximum, rel=1e-6)


@pytest.mark.quality
def test_result_contents(paper_runs):
    r = paper_runs["pso"]
    assert r.n == 81 and r.labels[0] == "P1" and r.labels[-1] == "P81"
    s = r.substitute
    assert isinstance(s, Part.BSplineSurface) and (s.NbUPoles, s.NbVPoles, s.UDegree) == (6, 6, 3)
    assert r.settings["population"] == 25 and r.settings["iterations"] == 3000
    assert r.settings["fit_poles"] == [6, 6] and r.settings["grid"] == [60, 60]
    d = r.deviation
    assert d.mean <= d.rms <= d.maximum and math.isclose(d.rms ** 2, d.mean ** 2 + d.std ** 2, rel_tol=1e-9)
    largest = max(np.nanmax(d.field), np.abs(d.edge_signed).max(), np.abs(d.peak_signed).max(initial=0.0))
    assert largest == d.judged_maximum and np.nanmax(d.field) <= d.judged_maximum
    assert d.maximum == d.occ_maximum == pytest.approx(d.judged_maximum, rel=1e-9), "OCC confirms the headline"
    row = r.point_table()[0]
    assert row[0] == "P1" and len(row) == 9
    summary = r.summary()
    assert summary["max_mm"] == d.maximum and summary["strategy"] == "pso"


@pytest.mark.quality
def test_evaluate_reproduces_a_sampled_result(paper_runs):
    again = cmmsampling.evaluate(cmmsampling.reference_face(), paper_runs["pso"].uv, occ_check=False)
    assert again.deviation.maximum == pytest.approx(paper_runs["pso"].deviation.maximum, rel=1e-12)


def test_progress_is_reported_and_can_cancel(reference):
    seen = []
    result = cmmsampling.sample(reference, 25, "pso", iterations=50, occ_check=False,
                                progress=lambda k, best: seen.append((k, best)) or k >= 10)
    assert result.cancelled and len(seen) == 10 and len(result.history) == 10
    assert seen[-1][1] > 0 and seen[-1][1] != result.history[-1]   # the exact figure, not the swarm's estimate


def test_pso_never_worse_than_the_uniform_layouts(reference):
    result = cmmsampling.sample(reference, 49, "pso", iterations=2, occ_check=False)
    for name in ("uniform_parametric", "uniform_cartesian"):
        uniform = cmmsampling.sample(reference, 49, name, occ_check=False)
        assert result.deviation.maximum <= uniform.deviation.maximum + 1e-12


def _pso(**kwargs):
    """Arguments of a short PSO run, with the given ones replaced."""
    return {"n": 25, "strategy": "pso", "iterations": 2, **kwargs}


BAD = [
    (_pso(n=3), ValueError, "n must be at least 4"),
    (_pso(n=81.5), TypeError, "n must be a whole number"),
    (_pso(n="81"), TypeError, "n must be a whole number"),
    (_pso(iterations=0), ValueError, "iterations must be at least 1"),
    (_pso(population=1), ValueError, "population must be at least 2"),
    (_pso(c1=float("nan")), ValueError, "c1 must be a finite number"),
    (_pso(c2=-1.0), ValueError, "c2 must be at least 0"),
    (_pso(w1=0.2, w2=0.5), ValueError, "inertia must decrease"),
    (_pso(w1=1.5), ValueError, "w1 must be at most 1.2"),
    (_pso(grid=1), ValueError, "grid must be at least 2"),
    (_pso(grid=(60, 60, 3)), ValueError, "grid must be one whole number or a pair"),
    (_pso(fit_poles=3), ValueError, "fit_poles along u \\(3\\) must be at least fit_degree \\+ 1 \\(4\\)"),
    (_pso(smoothing=0), ValueError, "smoothing must be greater than 0"),
    ({"strategy": "spiral"}, ValueError, "unknown strategy 'spiral'; choose one of .*'pso'"),
    ({"strategy": "halton", "iterations": 5}, TypeError, "strategy 'halton' does not take iterations"),
    (_pso(swarm=5), TypeError, "does not take swarm; it takes population"),
]


@pytest.mark.parametrize("kwargs, error, message", BAD)
def test_bad_input_gets_a_clear_message(reference, kwargs, error, message):
    with pytest.raises(error, match=message):
        cmmsampling.sample(reference, **kwargs)


def test_bad_faces_get_a_clear_message():
    with pytest.raises(TypeError, match="expected one face, got a Solid with 6 faces"):
        cmmsampling.sample(Part.makeBox(1, 2, 3), 25, "uniform_parametric")
    with pytest.raises(TypeError, match="expected a face, got an Edge with no faces"):
        cmmsampling.sample(Part.makeLine((0, 0, 0), (1, 0, 0)), 25, "uniform_parametric")
    with pytest.raises(TypeError, match="expected a Part.Face, got NoneType"):
        cmmsampling.sample(None, 25, "uniform_parametric")
    from cmmsampling.geometry.surface import make_bspline_surface

    x, y = np.meshgrid(np.linspace(0, 10, 4), np.linspace(0, 10, 4), indexing="ij")
    flat_line = np.stack([x + y, np.zeros_like(x), np.zeros_like(x)], -1)
    collapsed = make_bspline_surface(flat_line, (3, 3)).toShape()
    with pytest.raises(ValueError, match="no usable area"):
        cmmsampling.sample(collapsed, 25, "uniform_parametric")
