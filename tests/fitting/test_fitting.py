"""Substitute fit and deviation objective: exactness, batching, uniqueness, OCC agreement."""
import numpy as np
import pytest
from support.faces import Part

from cmmsampling.fitting.deviation import EvaluationGrid, deviation_objective
from cmmsampling.fitting.exact import exact_deviation
from cmmsampling.fitting.substitute import BANDED_LIMIT, DEFAULT_SMOOTHING, SubstituteSpace, default_pole_count
from cmmsampling.fitting.occ_surface import substitute_surface
from cmmsampling.geometry.surface import SurfaceModel, make_bspline_surface


def _bicubic_face(poles=(6, 6), seed=1):
    """A non-rational bicubic face on [0, 1]^2 with clamped uniform knots: it lies in the 6 x 6 space."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 50, poles[0]), np.linspace(0, 40, poles[1]), indexing="ij")
    z = rng.normal(0, 3, x.shape)
    return make_bspline_surface(np.stack([x, y, z], -1), (3, 3)).toShape(), np.stack([x, y, z], -1)


@pytest.mark.parametrize("smoothing, tolerance", [(1e-14, 1e-8), (DEFAULT_SMOOTHING, 1e-4)])
def test_fit_reproduces_a_surface_of_the_space(smoothing, tolerance):
    """A rough bicubic surface (poles +-3 mm) from a 9 x 9 grid: exact up to the smoothing's pull."""
    face, poles = _bicubic_face()
    model = SurfaceModel.from_face(face)
    space = SubstituteSpace((3, 3), (6, 6), model.bounds, smoothing)
    grid = np.stack(np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 1, 9), indexing="ij"), -1)
    uv = grid.reshape(-1, 2)
    fitted = space.fit(uv, model.points(uv))
    assert np.abs(fitted - poles).max() < tolerance
    objective = deviation_objective(model, space, EvaluationGrid(model, 40))
    assert np.abs(objective.expanded_field(fitted)[objective.counted]).max() < tolerance


def test_batched_fit_equals_single_fits(reference):
    model = SurfaceModel.from_face(reference)
    space = SubstituteSpace((3, 3), (6, 6), model.bounds)
    uv = np.random.default_rng(5).random((4, 30, 2))
    batched = space.fit(uv, model.points(uv))
    for p in range(4):
        single = space.fit(uv[p], model.points(uv[p]))
        assert np.allclose(batched[p], single, atol=1e-10)


@pytest.mark.parametrize("layout", ["cluster", "coincident", "collinear"])
def test_degenerate_point_sets_still_have_a_finite_fit(reference, layout):
    model = SurfaceModel.from_face(reference)
    space = SubstituteSpace((3, 3), (6, 6), model.bounds)
    uv = {
        "cluster": 0.5 + 1e-3 * np.random.default_rng(1).random((20, 2)),
        "coincident": np.full((20, 2), 0.5),
        "collinear": np.column_stack([np.linspace(0, 1, 20), np.full(20, 0.3)]),
    }[layout]
    poles = space.fit(uv, model.points(uv))
    assert np.all(np.isfinite(poles)) and np.abs(poles).max() < 1e3
    if layout != "collinear":
        assert np.abs(space.evaluate(poles, uv) - model.points(uv)).max() < 1e-4


def test_fitted_part_surface_matches_our_evaluation(reference):
    model = SurfaceModel.from_face(reference)
    space = SubstituteSpace((3, 3), (7, 5), model.bounds)
    uv = np.random.default_rng(2).random((60, 2))
    poles = space.fit(uv, model.points(uv))
    part = substitute_surface(space, poles)
    check = np.random.default_rng(3).random((25, 2))
    ours = space.evaluate(poles, check)
    occ = np.array([tuple(part.value(u, v)) for u, v in check])
    assert np.abs(ours - occ).max() < 1e-9 * 100
    assert (part.NbUPoles, part.NbVPoles, part.UDegree) == (7, 5, 3)


def test_exact_distances_agree_with_occ_and_the_expansion_is_close(reference):
    """Both sides of the exact deviation are OCC's closest-point distances: from the nodes to the
    delivered substitute, and from its points at the nodes' parameters back to the face; the
    swarm's expansion is within 2% of them at the maximum."""
    model = SurfaceModel.from_face(reference)
    space = SubstituteSpace((3, 3), (6, 6), model.bounds)
    objective = deviation_objective(model, space, EvaluationGrid(model, (30, 25)))
    grid = np.stack(np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 1, 9), indexing="ij"), -1).reshape(-1, 2)
    uv = np.clip(grid + 0.03 * np.random.default_rng(4).standard_normal((3, 81, 2)), 0, 1)
    maxima = objective(uv)
    poles = objective.fit(uv)[1]
    exact = exact_deviation(space, poles, objective.nodes, objective.model)
    assert maxima[1] == pytest.approx(exact.maximum, rel=0.02)
    part = substitute_surface(space, poles)
    forward = np.argsort(np.abs(exact.forward.values))[-20:]
    nodes = exact.points()[forward]
    occ = np.array([part.toShape().distToShape(Part.Vertex(*map(float, p)))[0] for p in nodes])
    assert np.abs(occ - np.abs(exact.forward.values[forward])).max() < 1e-6 * occ.max()
    reverse = np.argsort(np.abs(exact.reverse.values))[-20:]
    points = [part.value(*map(float, uv)) for uv in exact.reverse.at[reverse]]
    occ = np.array([reference.distToShape(Part.Vertex(p))[0] for p in points])
    assert np.abs(occ - np.abs(exact.reverse.values[reverse])).max() < 1e-6 * occ.max()


@pytest.mark.parametrize("n, expected", [(25, 4), (49, 5), (81, 6), (144, 8), (400, 13), (4, 4)])
def test_default_pole_count(n, expected):
    assert default_pole_count(n) == expected


@pytest.mark.parametrize("degrees, poles", [((3, 3), (6, 6)), ((3, 2), (13, 5)), ((5, 1), (6, 9)), ((2, 3), (3, 4))])
def test_band_normal_matrix_equals_the_dense_one(degrees, poles):
    """B^T B from band pair products against the dense product of the Kronecker rows."""
    space = SubstituteSpace(degrees, poles, (0.0, 2.0, -1.0, 1.0), smoothing=0.0)
    uv = np.random.default_rng(3).random((4, 40, 2)) * [2.0, 2.0] - [0.0, 1.0]
    along_u, along_v = space.u_basis.values(uv[..., 0]), space.v_basis.values(uv[..., 1])
    rows = along_u[:, :, None, :] * along_v[:, None, :, :]
    rows = rows.reshape(4, space.size, 40)
    dense = np.matmul(rows, np.swapaxes(rows, -1, -2))
    assert np.allclose(space.normal_matrix(along_u, along_v), dense, rtol=0, atol=1e-13)
    points = np.random.default_rng(4).normal(size=(4, 3, 40))
    assert np.allclose(space.right_hand_side(along_u, along_v, points),
                       np.matmul(rows, np.swapaxes(points, -1, -2)), rtol=0, atol=1e-12)


def _normal_equations(space, sets=7, count=60, seed=3):
    """Pair products (P, L_u, L_v), the smoothing's weight and B^T Q (P, M, 3) of random point sets."""
    uv = np.random.default_rng(seed).random((sets, count, 2)) * [2.0, 2.0] - [0.0, 1.0]
    along_u, along_v = space.u_basis.values(uv[..., 0]), space.v_basis.values(uv[..., 1])
    pairs = space.pair_products(along_u, along_v)
    points = np.random.default_rng(seed + 1).normal(size=(sets, 3, count))
    weight = space.smoothing * count / space.size
    return pairs, weight, space.right_hand_side(along_u, along_v, points)


@pytest.mark.parametrize("degrees, poles", [((3, 3), (6, 6)), ((3, 2), (13, 5)), ((5, 1), (6, 9)), ((2, 3), (3, 4)),
                                            ((1, 1), (4, 7)), ((3, 3), (21, 21))])
def test_banded_solve_equals_the_dense_one_and_each_set_is_alone_in_its_batch(degrees, poles):
    """The batch's banded Cholesky solve against LU of the dense normal matrix, and each set's poles
    bit for bit the same alone, in a batch of one, or in another split of the batch (as the two
    processes of a swarm split it). 21 x 21 bicubic poles pass BANDED_LIMIT: solved densely."""
    space = SubstituteSpace(degrees, poles, (0.0, 2.0, -1.0, 1.0))
    assert (space.bandwidth > BANDED_LIMIT) == (poles == (21, 21))
    pairs, weight, rhs = _normal_equations(space)
    dense = np.linalg.solve(space.gram_from_pairs(pairs, weight), rhs)
    solved = space.solve_normal(pairs, weight, rhs)
    assert np.abs(solved - dense).max() < 1e-8 * np.abs(dense).max()
    alone = np.stack([space.solve_normal(pairs[i], weight, rhs[i]) for i in range(len(pairs))])
    split = np.concatenate([space.solve_normal(pairs[:3], weight, rhs[:3]), space.solve_normal(pairs[3:], weight, rhs[3:])])
    assert np.array_equal(alone, solved) and np.array_equal(split, solved)


def test_a_set_lapack_finds_indefinite_is_solved_by_lu_and_the_others_as_ever():
    """A normal matrix made indefinite (a negative entry on its diagonal, as rounding can leave one
    of a degenerate set): that set alone is solved by LU, whatever its place in the batch."""
    space = SubstituteSpace((3, 3), (6, 6), (0.0, 2.0, -1.0, 1.0))
    pairs, weight, rhs = _normal_equations(space)
    pairs[2, 0, 0] = -pairs[2, 0, 0]
    pairs[5, 0, 0] = -pairs[5, 0, 0]
    solved = space.solve_normal(pairs, weight, rhs)
    for index in (2, 5):
        assert np.array_equal(solved[index], np.linalg.solve(space.gram_from_pairs(pairs[index], weight), rhs[index]))
    healthy = [0, 1, 3, 4, 6]
    assert np.array_equal(solved[healthy], space.solve_normal(pairs[healthy], weight, rhs[healthy]))
