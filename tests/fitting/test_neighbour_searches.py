"""The neighbour searches that replaced all-pairs arrays (memory linear in N) against all pairs."""
import numpy as np
import pytest

from cmmsampling.fitting import deviation
from cmmsampling.fitting.deviation import closest_squared
from cmmsampling.strategies.optimal import _spacing_penalty
from cmmsampling.strategies.blind import spaced


def all_pairs_distances(points):
    """(N, N) distances of points (N, 3), inf on the diagonal: the reference."""
    distance = np.linalg.norm(points[:, None] - points[None], axis=-1)
    np.fill_diagonal(distance, np.inf)
    return distance


@pytest.mark.parametrize("sets, count", [(25, 81), (3, 1500)])
def test_closest_squared_by_pairs_and_by_tree_agree_with_all_pairs(monkeypatch, sets, count):
    rng = np.random.default_rng(count)
    points = rng.uniform(-50, 50, (sets, 3, count))
    points[0, :, 7] = points[0, :, 3] + 1e-4          # a close pair in the first set
    expected = [all_pairs_distances(p.T).min() ** 2 for p in points]
    assert np.allclose(closest_squared(points), expected, rtol=1e-9, atol=1e-12)
    monkeypatch.setattr(deviation, "PAIRWISE_LIMIT", 0)
    assert np.allclose(closest_squared(points), expected, rtol=1e-6, atol=1e-12)


def test_spacing_penalty_agrees_with_all_pairs_and_its_gradient_with_differences():
    rng = np.random.default_rng(4)
    points = rng.uniform(0, 10, (60, 3))
    points[5] = points[9]                              # a coincident pair: no gradient from it
    spacing, weight = 2.5, 3.0
    distance = all_pairs_distances(points)
    short = np.maximum(spacing - distance, 0.0)
    value, gradient, closest = _spacing_penalty(points, spacing, weight)
    assert closest == pytest.approx(distance.min(), abs=1e-12)
    assert value == pytest.approx(0.5 * weight * (short ** 2).sum(), rel=1e-12)
    step = 1e-6
    for i in (0, 17, 42):
        for axis in range(3):
            moved = points.copy()
            moved[i, axis] += step
            ahead = _spacing_penalty(moved, spacing, weight)[0]
            moved[i, axis] -= 2 * step
            behind = _spacing_penalty(moved, spacing, weight)[0]
            assert gradient[i, axis] == pytest.approx((ahead - behind) / (2 * step), rel=1e-5, abs=1e-6)


def greedy_reference(points, spacing):
    """The greedy subset by plain loops: the reference for strategies.spaced."""
    kept = []
    for i, point in enumerate(points):
        if all(np.linalg.norm(points[j] - point) >= spacing for j in kept):
            kept.append(i)
    return kept


def test_spaced_keeps_the_same_greedy_subset_as_plain_loops():
    rng = np.random.default_rng(2)
    points = rng.uniform(0, 20, (400, 3))
    points[10] = points[3]
    assert spaced(points, 1.7).tolist() == greedy_reference(points, 1.7)
    assert spaced(points, 0.0).tolist() == list(range(400))
    for block in (1, 7, 64, 399):
        assert spaced(points, 1.7, block=block).tolist() == greedy_reference(points, 1.7), block


def test_spaced_thins_a_crowd_in_bounded_memory():
    """Ventilator Face296 with uniform Cartesian: about 20,000 footprint-grid points fell within
    the spacing of each other (77 million pairs, 1.7 GiB per array before); in blocks the pairs
    in memory stay below SPACING_BLOCK^2 / 2."""
    rng = np.random.default_rng(5)
    crowd = rng.normal(0.0, 1e-3, (20000, 3))
    kept = spaced(crowd, 0.05)
    assert len(kept) < 10 and kept[0] == 0
    chosen = crowd[kept]
    gaps = np.linalg.norm(chosen[:, None] - chosen[None], axis=-1) + np.diag(np.full(len(kept), np.inf))
    assert gaps.min() >= 0.05
