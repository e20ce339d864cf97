"""The strategy study (compare) and its report (write_report): numbers, seeds, bounds, cancel, figures."""
import base64
import re

import numpy as np
import pytest
from support.faces import Part

import cmmsampling
from cmmsampling.study import FIGURES, write_report
from cmmsampling.strategies.result import footprint
from cmmsampling.gui.handover import handed
from cmmsampling.study import MEASURES, compare, study_time
from cmmsampling.geometry.surface import SurfaceModel

SAMPLE_OPTIONS = {"pso": {"iterations": 20, "population": 10}, "optimal": {"max_evaluations": 150}}
SMALL = {"grid": 20, "options": SAMPLE_OPTIONS, "workers": 1}


@pytest.fixture(scope="module")
def calls():
    return []


@pytest.fixture(scope="module")
def study(reference, calls):
    """Every strategy at N = 16 and 25 on a 20 x 20 grid; random and PSO over three seeds."""
    return compare(reference, ns=(25, 16), seeds=(0, 1, 2), seeded=("random", "pso"),
                   progress=lambda *call: calls.append(call) and False, **SMALL)


def separate(reference, n, strategy, seed):
    """The same run as a plain sample() call."""
    return cmmsampling.sample(reference, n, strategy, seed=seed, grid=SMALL["grid"], occ_check=False,
                              workers=1, **SAMPLE_OPTIONS.get(strategy, {}))


def row(study, strategy, n, seed):
    (found,) = [r for r in study.rows if (r.strategy, r.n, r.seed) == (strategy, n, seed)]
    return found


@pytest.mark.parametrize("strategy", sorted(cmmsampling.self_contained()))
def test_every_run_matches_a_separate_sample_call(study, reference, strategy):
    seeds = (0, 2) if strategy in ("random", "pso") else (0,)
    for seed in seeds:
        result, run = separate(reference, 25, strategy, seed), row(study, strategy, 25, seed)
        assert run.max_mm == pytest.approx(result.deviation.maximum, rel=1e-12)
        assert run.mean_mm == pytest.approx(result.deviation.mean, rel=1e-12)
        assert run.rms_mm == pytest.approx(result.deviation.rms, rel=1e-12)
        assert run.check_max_mm == pytest.approx(result.check.maximum, rel=1e-12)
        assert run.evaluations == result.evaluations and run.time_s > 0


def test_study_layout(study):
    assert study.ns == (16, 25) and study.strategies == tuple(cmmsampling.self_contained())
    assert not study.cancelled and study.elapsed_s > 0
    assert len(study.rows) == 2 * (7 + 3 + 3)
    assert study.figure_n == 25 and set(study.results) == set(cmmsampling.self_contained())
    assert all(r.n == 25 for r in study.results.values())
    assert study.results["random"].deviation.maximum == row(study, "random", 25, 0).max_mm


def test_bounds_are_about_the_best_run_at_each_n(study, reference):
    for n in study.ns:
        strategy, seed = study.bound_about[n]
        best = min((r for r in study.rows if r.n == n), key=lambda r: r.check_max_mm)
        assert (best.strategy, best.seed) == (strategy, seed)
        again = cmmsampling.sample(reference, n, strategy, seed=seed, occ_check=False, workers=1,
                                   grid=SMALL["grid"], **SAMPLE_OPTIONS.get(strategy, {}))
        bounds = again.bounds()
        assert study.bounds[n] == (pytest.approx(bounds["grid"].lower, rel=1e-9),
                                   pytest.approx(bounds["check"].lower, rel=1e-9))
        assert study.bounds[n].grid <= best.max_mm * (1 + 1e-6)


def test_ratios_to_uniform_and_multiples_of_the_bound(study):
    for run in study.rows:
        base = row(study, "uniform_parametric", run.n, 0)
        assert run.ratio_max == pytest.approx(run.max_mm / base.max_mm)
        assert run.ratio_mean == pytest.approx(run.mean_mm / base.mean_mm)
        assert run.ratio_rms == pytest.approx(run.rms_mm / base.rms_mm)
        assert run.bound_multiple == pytest.approx(run.max_mm / study.bounds[run.n].grid)
        assert run.check_bound_multiple == pytest.approx(run.check_max_mm / study.bounds[run.n].check)
        assert run.bound_multiple >= 1.0 and run.check_bound_multiple >= 1.0
    assert row(study, "uniform_parametric", 16, 0).ratio_max == 1.0


def test_seeded_strategies_report_mean_and_spread(study):
    for strategy in ("random", "pso"):
        aggregate = study.aggregate(strategy, 16)
        maxima = np.array([row(study, strategy, 16, seed).max_mm for seed in (0, 1, 2)])
        assert aggregate.seeds == (0, 1, 2)
        assert aggregate.mean["max_mm"] == pytest.approx(maxima.mean())
        assert aggregate.std["max_mm"] == pytest.approx(maxima.std()) and aggregate.std["max_mm"] > 0
        assert aggregate.low["max_mm"] == maxima.min() and aggregate.high["max_mm"] == maxima.max()
    single = study.aggregate("hammersley", 16)
    assert single.seeds == (0,) and all(single.std[m] == 0 for m in MEASURES)
    matrix = study.matrix("max_mm", "std")
    assert matrix.shape == (9, 2) and matrix[list(study.strategies).index("random"), 0] > 0


def test_table_lists_every_strategy_and_n(study):
    lines = study.table().splitlines()
    assert len(lines) == 1 + 2 * 9 + 2
    for strategy in study.strategies:
        assert sum(line.split()[0] == strategy for line in lines[1:]) == 2
    random_line = next(line for line in lines if line.startswith("random") and line.split()[1] == "25")
    aggregate = study.aggregate("random", 25)
    assert f"{aggregate.mean['max_mm']:.4f}" in random_line
    assert f"{aggregate.std['max_mm']:.4f}" in random_line


def test_progress_reports_every_step_then_completion(study, calls):
    steps = [c for c in calls if "iteration" not in c[2] and "evaluation" not in c[2]]
    total = 2 * (1 + 13)
    assert [c[0] for c in steps] == list(range(total + 1))
    assert all(c[1] == total for c in calls) and steps[-1][2] == "study complete"
    assert steps[13][2] == "N = 16: local bound about the best"
    assert any(re.search(r"PSO \(paper\) \(seed 1\): iteration 20, best max \d", c[2]) for c in calls)
    assert any("optimal (this project) (seed 0): surrogate evaluation" in c[2] for c in calls)
    done = [c[0] for c in calls]
    assert done == sorted(done)


def test_cancel_between_runs_returns_what_is_done(reference):
    cancelled = compare(reference, ns=(16, 25), strategies=("uniform_parametric", "random"), seeds=(0, 1),
                        progress=lambda done, total, message: done == 4, **SMALL)
    assert cancelled.cancelled
    assert [(r.strategy, r.n, r.seed) for r in cancelled.rows] == [
        ("uniform_parametric", 16, 0), ("random", 16, 0), ("random", 16, 1)]
    assert list(cancelled.bounds) == [16] and cancelled.results == {}
    assert cancelled.rows[1].ratio_max == pytest.approx(cancelled.rows[1].max_mm / cancelled.rows[0].max_mm)
    assert "cancelled" in cancelled.table()


def test_cancel_inside_the_swarm_drops_the_interrupted_run(reference):
    stop = compare(reference, ns=(16,), strategies=("uniform_parametric", "pso", "halton"),
                   progress=lambda done, total, message: "iteration 5," in message, **SMALL)
    assert stop.cancelled and [r.strategy for r in stop.rows] == ["uniform_parametric"]
    assert set(stop.results) == {"uniform_parametric"}


def test_a_report_handed_over_is_taken_once_by_the_same_study_and_folder(study, tmp_path):
    folder = str(tmp_path / "report")
    with handed("write_report", study, {"folder": folder}, "written/elsewhere.html"):
        assert cmmsampling.write_report(study, folder) == "written/elsewhere.html"
        assert not (tmp_path / "report").exists()
        assert cmmsampling.write_report(study, folder) == str(tmp_path / "report" / "report.html")
    with handed("write_report", study, {"folder": folder}, "written/elsewhere.html"):
        assert cmmsampling.write_report(study, str(tmp_path / "other")) == str(tmp_path / "other" / "report.html")
    assert cmmsampling.write_report(study, folder) == str(tmp_path / "report" / "report.html")


def test_report_writes_every_figure_and_embeds_them(study, tmp_path):
    path = write_report(study, str(tmp_path / "report"))
    assert path == str(tmp_path / "report" / "report.html")
    page = open(path, encoding="utf-8").read()
    embedded = re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", page)
    assert len(embedded) == len(FIGURES)
    for (name, _, _), encoded in zip(FIGURES, embedded):
        png = (tmp_path / "report" / f"{name}.png").read_bytes()
        assert len(png) > 10000 and png.startswith(b"\x89PNG")
        assert base64.b64decode(encoded) == png
    pso = study.aggregate("pso", 25)
    assert f"{pso.mean['max_mm']:.4f} ± {pso.std['max_mm']:.4f}" in page
    assert f"{study.bounds[16].grid:.4f}" in page and "PSO (paper)" in page


def test_report_of_a_study_cancelled_before_the_figures_n(reference, tmp_path):
    early = compare(reference, ns=(16, 25), strategies=("uniform_parametric", "hammersley"),
                    progress=lambda done, total, message: done == 3, **SMALL)
    path = write_report(early, str(tmp_path))
    page = open(path, encoding="utf-8").read()
    assert "cancelled" in page and page.count("data:image/png;base64,") == 1
    assert (tmp_path / "max_vs_n.png").stat().st_size > 0
    assert not (tmp_path / "substitutes.png").exists()


def test_maps_fall_back_to_parameters_on_a_folded_face(reference, tmp_path):
    cylinder = Part.makeCylinder(10, 20).Faces[0]
    model = SurfaceModel.from_face(cylinder)
    assert footprint(model, model.raster((20, 20))) is None
    flat = SurfaceModel.from_face(reference)
    xy, names, _ = footprint(flat, flat.raster((20, 20)))
    assert names == ("x", "y") and xy.shape == (20, 20, 2)
    small = compare(cylinder, ns=(16,), strategies=("uniform_parametric", "halton"), **SMALL)
    write_report(small, str(tmp_path))
    assert (tmp_path / "deviation_maps.png").stat().st_size > 0


@pytest.mark.parametrize("bad, error", [
    ({"ns": ()}, ValueError),
    ({"ns": (16, 3)}, ValueError),
    ({"ns": (16.5,)}, TypeError),
    ({"strategies": ["uniform", "pso"]}, ValueError),
    ({"seeds": ()}, ValueError),
    ({"seeded": ("lucky",)}, ValueError),
    ({"options": {"pso": {"swarm": 3}}}, TypeError),
    ({"options": {"optimal": {"max_evaluations": 0}}}, ValueError),
    ({"options": {"swarm": {"iterations": 3}}}, ValueError),
    ({"options": {"pso": 3}}, TypeError),
    ({"figure_n": 30}, ValueError),
    ({"progress": 5}, TypeError),
    ({"grid": 1}, ValueError),
    ({"workers": 3}, ValueError),
])
def test_bad_input_fails_before_any_run(reference, bad, error):
    calls = []
    with pytest.raises(error):
        compare(reference, **{"ns": (16,), "progress": lambda *call: calls.append(call), **bad})
    assert calls == []


def test_the_probe_constraints_hold_in_every_run_as_in_sample(reference):
    constrained = compare(reference, ns=(16,), strategies=("halton", "pso"),
                          options={"pso": {"iterations": 5, "population": 4}}, grid=20,
                          edge_offset=6.0, min_spacing=9.0)
    for strategy, result in constrained.results.items():
        assert (result.settings["edge_offset"], result.settings["min_spacing"]) == (6.0, 9.0)
        alone = cmmsampling.sample(reference, 16, strategy, grid=20, edge_offset=6.0, min_spacing=9.0,
                                   occ_check=False, **({"iterations": 5, "population": 4} if strategy == "pso" else {}))
        np.testing.assert_allclose(result.uv, alone.uv)
        gaps = np.linalg.norm(result.points[:, None] - result.points[None], axis=-1) + np.diag(np.full(16, np.inf))
        assert gaps.min() >= 9.0 - 1e-9


def test_the_study_time_counts_every_run_and_names_the_open_ended(reference):
    runs, seconds, open_ended = study_time(reference, ns=(16, 25), strategies=("halton", "pso", "optimal"),
                                           options={"pso": {"iterations": 50}}, grid=20)
    assert seconds > 0 and open_ended == ["optimal"] and runs == 6
    _, longer, _ = study_time(reference, ns=(16, 25), strategies=("halton", "pso"),
                              options={"pso": {"iterations": 5000}}, grid=20)
    assert longer > seconds
    assert study_time(reference, ns=(16,), strategies=("random", "halton"), seeds=(0, 1, 2), grid=20).runs == 4


def test_a_handed_over_study_is_returned_once_for_exactly_its_call(reference):
    arguments = {"ns": [16], "strategies": ["halton"], "grid": 20}
    made = compare(reference, **arguments)
    with handed("compare", reference, arguments, made):
        assert cmmsampling.compare(reference, grid=20, ns=[16], strategies=["halton"]) is made
        again = cmmsampling.compare(reference, **arguments)
    assert again is not made and again.rows[0].max_mm == made.rows[0].max_mm
    with handed("compare", reference, arguments, made):
        assert cmmsampling.compare(reference, ns=[16], strategies=["hammersley"], grid=20) is not made
        assert cmmsampling.compare(cmmsampling.reference_face(), **arguments) is not made
    assert cmmsampling.compare is compare
