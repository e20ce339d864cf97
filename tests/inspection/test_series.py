"""The series' error: the model learnt from earlier parts, part_error's points, the error map.

At the probing noise's floor any nine points pin a next part down once the model is known (the
benchmark series-error shows part_error and uniform points within a tenth of a micrometre there),
so the test holds part_error to what its design promises: a smaller expected error under the model
than uniform points, and a real map error far below uniform points without the model."""
import numpy as np
import pytest

import cmmsampling
from cmmsampling.cli import main as cli_main
from cmmsampling.fitting import series as series_fit
from cmmsampling.fitting.series import SeriesModel, fit_field, greedy_design
from cmmsampling.strategies import part_error
from cmmsampling.strategies.registry import baseline

NOISE = 0.0005
DENSE = 144


@pytest.fixture(scope="module")
def series():
    """(face, the simulated parts, the first three parts' inspections, their series model, a raster uv)."""
    face = cmmsampling.reference_face()
    parts = cmmsampling.simulated_series(face, 6, "all", 0.02, seed=3)
    dense = cmmsampling.sample(face, DENSE, baseline(), occ_check=False).uv
    prior = [cmmsampling.inspect(face, cmmsampling.measured_part(face, dense, part, NOISE, seed=k), alignment="none")
             for k, part in enumerate(parts[:3])]
    u0, u1, v0, v1 = face.ParameterRange
    u, v = np.meshgrid(np.linspace(u0, u1, 30), np.linspace(v0, v1, 30), indexing="ij")
    return face, parts, prior, cmmsampling.series_model(face, prior), np.column_stack([u.ravel(), v.ravel()])


def rms(values):
    return float(np.sqrt(np.mean(np.square(values))))


def test_the_series_model_finds_the_systematic_error_of_the_first_parts(series):
    face, parts, _, model, grid = series
    truth = np.mean([part.error(grid) for part in parts[:3]], axis=0)
    assert rms(model.systematic(grid) - truth) < 0.05 * rms(truth)
    assert 0.5 * NOISE < np.sqrt(model.noise) < 2 * NOISE, "the probing noise is learnt from the parts' scatter"


def test_kriging_one_part_follows_its_error_and_ignores_the_noise():
    x = np.random.default_rng(0).uniform(0, 50, (200, 2))
    smooth = lambda p: 0.01 * np.sin(p[:, 0] / 8) * np.cos(p[:, 1] / 11)  # noqa: E731
    fit = fit_field(x, smooth(x) + np.random.default_rng(1).normal(0, 0.001, len(x)))
    query = np.random.default_rng(2).uniform(5, 45, (300, 2))
    assert rms(fit(query) - smooth(query)) < 0.15 * rms(smooth(query))
    assert 0.5e-3 < np.sqrt(fit.noise) < 2e-3


def test_part_error_with_the_model_maps_the_next_parts_better_than_uniform_points(series):
    face, parts, _, model, grid = series
    layouts = {name: cmmsampling.sample(face, 9, name, occ_check=False, **options).uv
               for name, options in ((baseline(), {}), ("part_error", {"prior": model}))}
    found = {}
    for k, part in enumerate(parts[3:]):
        for name, uv in layouts.items():
            inspection = cmmsampling.inspect(face, cmmsampling.measured_part(face, uv, part, NOISE, 50 + k),
                                             alignment="none")
            truth = part.error(grid)
            found.setdefault((name, True), []).append(rms(inspection.deviation_map(grid, prior=model) - truth))
            found.setdefault((name, False), []).append(rms(inspection.deviation_map(grid) - truth))
    mean = {key: np.mean(values) for key, values in found.items()}
    assert mean["part_error", True] < 0.5 * mean[baseline(), False]
    expected = {name: rms(model.predict(uv, np.zeros(len(uv)), grid)[1]) for name, uv in layouts.items()}
    assert expected["part_error"] < expected[baseline()], "the model knows the next part better at its points"


def test_the_maps_posterior_is_the_textbook_one_of_the_models_covariance(series):
    face, parts, _, model, grid = series
    uv = cmmsampling.sample(face, 16, "halton", occ_check=False).uv
    measured = parts[4].error(uv)
    mean, sd = model.predict(uv, measured, grid)
    among = model.covariance(uv, uv) + model.noise * np.eye(len(uv))
    cross = model.covariance(grid, uv)
    expected = model.systematic(grid) + cross @ np.linalg.solve(among, measured - model.systematic(uv))
    variance = np.diag(model.covariance(grid, grid)) - np.einsum("ij,ji->i", cross, np.linalg.solve(among, cross.T))
    assert np.allclose(mean, expected, rtol=0, atol=1e-6 * rms(expected))
    assert np.allclose(sd ** 2, variance, rtol=0, atol=1e-6 * variance.max())
    assert np.allclose(model.variance(grid), np.diag(model.covariance(grid, grid)))


def test_the_greedy_designs_variances_are_those_the_map_finds_at_its_points(series):
    face, _, _, model, grid = series
    candidates = cmmsampling.sample(face, 200, "halton", occ_check=False, edge_offset=2.0).uv
    chosen, variances = greedy_design(model, candidates, 10, judged=grid)
    assert len(set(chosen.tolist())) == 10
    assert np.allclose(variances, model.predict(candidates[chosen], np.zeros(10), grid)[1] ** 2,
                       rtol=0, atol=1e-6 * variances.max())
    own = greedy_design(model, candidates, 10)[1]
    assert own.shape == (len(candidates),), "without judged places the variance is summed over the candidates"


def test_part_error_records_what_the_model_expects(series):
    face, _, prior, _, _ = series
    result = cmmsampling.sample(face, 12, "part_error", prior=prior, occ_check=False)
    assert result.n == 12 and 0 < result.settings["expected_rms_mm"] <= result.settings["expected_max_sd_mm"]
    assert result.settings["prior"] == "3 earlier parts"
    u0, u1, v0, v1 = face.ParameterRange
    u, v = np.meshgrid(np.linspace(u0, u1, part_error.JUDGED), np.linspace(v0, v1, part_error.JUDGED), indexing="ij")
    sd = cmmsampling.series_model(face, prior).predict(result.uv, np.zeros(12), np.column_stack([u.ravel(), v.ravel()]))[1]
    assert result.settings["expected_rms_mm"] == pytest.approx(rms(sd), rel=1e-6), "over the whole face"
    assert any("least known" in note for note in result.notes)


def test_part_error_without_a_prior_is_refused_in_one_line():
    with pytest.raises(cmmsampling.InputError) as refused:
        cmmsampling.sample(cmmsampling.reference_face(), 9, "part_error")
    assert "give prior=" in str(refused.value) and "\n" not in str(refused.value)
    with pytest.raises(cmmsampling.InputError, match="not an inspection"):
        cmmsampling.sample(cmmsampling.reference_face(), 9, "part_error", prior=[1, 2])


@pytest.mark.quality
def test_a_study_runs_part_error_when_its_prior_is_given(series):
    face, _, _, model, _ = series
    quick = {"pso": {"iterations": 10}, "optimal": {"max_evaluations": 10}}
    study = cmmsampling.compare(face, ns=[9], options={"part_error": {"prior": model}, **quick}, seeds=[0])
    assert "part_error" in study.strategies and study.settings["options"]["part_error"]["prior"] == "SeriesModel"
    assert "part_error" not in cmmsampling.compare(face, ns=[9], strategies=[baseline()]).strategies


def test_the_series_model_needs_a_part():
    with pytest.raises(cmmsampling.InputError, match="at least one"):
        SeriesModel(None, [])


def test_the_command_line_samples_a_next_part_from_earlier_parts_files(series, tmp_path, capsys):
    face, parts, _, _, _ = series
    step = str(tmp_path / "part.step")
    face.exportStep(step)
    dense = cmmsampling.sample(face, 64, baseline(), occ_check=False).uv
    files = []
    for k, part in enumerate(parts[:2]):
        files += ["--prior", str(tmp_path / f"part{k}.csv")]
        cmmsampling.export(cmmsampling.measured_part(face, dense, part, NOISE, k), files[-1])
    arguments = ["sample", step, "--face", "1", "-n", "9", "--strategy", "part_error"]
    assert cli_main(arguments + files) == 0
    assert "least known" in capsys.readouterr().out
    assert cli_main(arguments) == 2
    assert capsys.readouterr().err.strip() == (
        "error: part_error learns where the series' parts err from earlier parts: give --prior FILE (an earlier "
        "part's measured points on this face) once per part")


def test_an_error_map_of_points_it_cannot_use_is_refused_in_one_line(monkeypatch):
    x = np.random.default_rng(2).uniform(0, 20, (12, 2))
    d = 0.01 * np.sin(x[:, 0] / 5)
    with pytest.raises(cmmsampling.InputError, match="finite points and deviations: drop the points"):
        fit_field(x, np.where(np.arange(12) == 3, np.nan, d))
    monkeypatch.setattr(series_fit, "_likelihood", lambda base, ratio, deviations: None)
    with pytest.raises(cmmsampling.InputError, match="no error map fits these 12 deviations"):
        fit_field(x, d)
