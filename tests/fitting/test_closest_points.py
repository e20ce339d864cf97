"""The closest-point search that both sides of the exact deviation stand on, against geometry
whose answer is known and against OpenCASCADE."""
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial import cKDTree
from support.faces import Part, collapsed_face, strip_face

import cmmsampling
from cmmsampling.fitting import exact
from cmmsampling.fitting.exact import _better, _nearest_on_edge_curves, closest_parameters, node_parameters, reverse_side
from cmmsampling.fitting.nodes import edge_pieces
from cmmsampling.fitting.substitute import FittedSurface
from cmmsampling.geometry.surface import SurfaceModel
from cmmsampling.strategies.sampling import make_problem

RADIUS = 10.0


class CountingModel:
    """A real surface model that counts the derivative evaluations the search asks of it (one per
    iteration)."""

    def __init__(self, model):
        self.model, self.bounds, self.calls = model, model.bounds, 0

    def points(self, uv):
        return self.model.points(uv)

    def derivatives(self, uv, order=1):
        self.calls += 1
        return self.model.derivatives(uv, order)


def _inside_cylinder(count=12, off_axis=1.0):
    """A cylinder of RADIUS mm as a NURBS model, targets (count, 3) 1 mm from its axis (each 9 mm
    from the surface, on its concave side, where Gauss-Newton alone creeps: the surface curves
    away faster than the distance falls), their exact closest angles and heights."""
    model = SurfaceModel.from_face(Part.makeCylinder(RADIUS, 20).Faces[0])
    angle = np.linspace(0.5, 5.5, count)
    height = np.linspace(3.0, 17.0, count)
    targets = np.column_stack([off_axis * np.cos(angle), off_axis * np.sin(angle), height])
    return model, targets, angle, height


def test_feet_on_the_concave_side_are_exact_within_a_few_dozen_iterations():
    model, targets, angle, height = _inside_cylinder()
    counting = CountingModel(model)
    start = np.column_stack([angle + 0.6, height + 2.0])
    feet = closest_parameters(counting, targets, start)
    distance = np.linalg.norm(model.points(feet) - targets, axis=1)
    assert np.abs(distance - (RADIUS - 1.0)).max() < 1e-9
    points = model.points(feet)
    # The distance is flat to second order about the foot: 2e-8 rad changes it by 1e-16 mm.
    assert np.abs(np.arctan2(points[:, 1], points[:, 0]) % (2 * np.pi) - angle).max() < 2e-8
    assert np.abs(points[:, 2] - height).max() < 1e-9
    assert counting.calls <= 40, f"{counting.calls} iterations (Gauss-Newton alone takes about 250)"


def test_a_search_ends_once_its_steps_fall_below_the_tolerance(monkeypatch):
    """Started at the feet themselves, no step gains: the steps there are rounding noise (about
    1e-9 of the box at most, and how large depends on the processor's rounding), so the search
    ends once they are below the tolerance, long before its damping, grown tenfold an iteration
    from 1e-9, could reach the ceiling of 1e12 (21 iterations). With a tolerance far above the
    rounding (1e-6 of the box), it ends at once, on any processor."""
    model, targets, angle, height = _inside_cylinder()
    feet = closest_parameters(model, targets, np.column_stack([angle + 0.6, height + 2.0]))
    counting = CountingModel(model)
    again = closest_parameters(counting, targets, feet)
    assert np.abs(again - feet).max() < 1e-9
    growths_to_the_ceiling = round(np.log10(exact.DAMPING_CEILING / 1e-9))
    assert counting.calls < growths_to_the_ceiling, f"{counting.calls} iterations from the feet themselves"
    monkeypatch.setattr(exact, "FOOT_STEP_TOLERANCE", 1e-6)
    counting = CountingModel(model)
    closest_parameters(counting, targets, feet)
    assert counting.calls == 1


def test_feet_agree_with_occ_on_a_strip_from_far_starts():
    """A 2 mm strip, targets 1-3 mm off it, every search started from the strip's far corner."""
    face = strip_face()
    model = SurfaceModel.from_face(face)
    u0, u1, v0, v1 = model.bounds
    rng = np.random.default_rng(4)
    uv = np.column_stack([u0 + rng.random(30) * (u1 - u0), v0 + rng.random(30) * (v1 - v0)])
    normals = model.normals(uv)
    targets = model.points(uv) + normals * rng.uniform(1.0, 3.0, (30, 1))
    feet = closest_parameters(model, targets, np.tile([u1, v1], (30, 1)))
    ours = np.linalg.norm(model.points(feet) - targets, axis=1)
    occ = np.array([face.Surface.toShape(u0, u1, v0, v1).distToShape(Part.Vertex(*t))[0] for t in targets])
    assert np.abs(ours - occ).max() < 1e-7


@pytest.mark.parametrize("make", [cmmsampling.reference_face, collapsed_face], ids=["reference", "collapsed_edge"])
def test_the_reverse_side_searches_again_only_from_another_nearest_node(make):
    """The reverse side searches each foot from the node's own parameters and, where another node
    lies nearer to S(h), from that node's too: the same feet as searching from both starts at
    every node (on a collapsed edge many nodes share one point, so the nearest is often another)."""
    problem = make_problem(make(), 25, grid=30)
    objective = problem.objective
    surface = FittedSurface(problem.space, objective.fit(np.asarray(
        cmmsampling.STRATEGIES["uniform_parametric"].run(problem, None).uv)[None])[0])
    side = reverse_side(surface, objective.nodes, objective.model, problem.domain.on_face)
    at = node_parameters(objective.nodes)
    points = surface.points(at)
    index = cKDTree(objective.nodes.all_points()[:len(at)]).query(points)[1]
    both = _better(objective.model, points, closest_parameters(objective.model, points, at),
                   closest_parameters(objective.model, points, at[index]))
    distance = np.linalg.norm(points - objective.model.points(both), axis=1)
    on_face = problem.domain.on_face(both)
    assert np.abs(np.abs(side.values[on_face]) - distance[on_face]).max() < 1e-9
    if make is collapsed_face:
        assert (index != np.arange(len(at))).any()


def sharp_corner_nodes():
    """Edge nodes of a thin triangle in the plane z = 0 (u, v = x, y): two 100 mm edges of 10
    segments each meeting a 1 mm edge of 200 tiny segments at sharp corners, each edge's samples
    from its start to its end (as SurfaceModel.trim_edges gives them)."""
    edges = [np.linspace([0.0, 0.0], [100.0, 0.0], 11), np.linspace([100.0, 0.0], [100.0, 1.0], 201),
             np.linspace([100.0, 1.0], [0.0, 0.0], 11)]
    uv = np.concatenate(edges)
    plane = flat_plane()
    runs = np.repeat([[0, 11], [11, 212], [212, 223]], [11, 201, 11], axis=0)
    nodes = SimpleNamespace(loops=[(0, len(uv))], edge_uv=uv, edge_points=plane.points(uv),
                            edge_normals=plane.normals(uv), edge_runs=runs)
    nodes.edge_pieces = edge_pieces(nodes)
    return nodes


def flat_plane():
    """The plane z = 0 as a face model: F(u, v) = (u, v, 0) mm, normal +z."""
    def points(uv):
        return np.column_stack([uv, np.zeros(len(uv))])

    def derivatives(uv, order):
        return {(0, 0): points(uv), (1, 0): np.tile([1.0, 0.0, 0.0], (len(uv), 1)),
                (0, 1): np.tile([0.0, 1.0, 0.0], (len(uv), 1))}

    return SimpleNamespace(points=points, derivatives=derivatives,
                           normals=lambda uv: np.tile([0.0, 0.0, 1.0], (len(uv), 1)))


def test_the_nearest_edge_point_is_found_beside_a_sharp_corner():
    """Points just off a long edge near a corner, where the nearest segment midpoints are all the
    short edge's: the nearest point is the one on the long edge, as a search of every segment
    finds (the first 8 midpoints alone gave a point on the short edge, overstating the distance)."""
    nodes = sharp_corner_nodes()
    points = np.column_stack([np.linspace(99.0, 99.95, 20), np.full(20, -0.02), np.zeros(20)])
    nearest, uv = _nearest_on_edge_curves(flat_plane(), nodes, points)
    assert np.allclose(nearest, points * [1.0, 0.0, 1.0], atol=1e-9)
    assert np.allclose(flat_plane().points(uv), nearest, atol=1e-12)
    middle = np.array([[50.0, -0.5, 0.0], [30.0, 0.3, 0.0]])
    assert np.allclose(_nearest_on_edge_curves(flat_plane(), nodes, middle)[0],
                       [[50.0, 0.0, 0.0], [30.0, 0.3, 0.0]], atol=1e-9)
