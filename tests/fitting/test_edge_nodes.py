"""The nodes along a face's edges (cmmsampling.fitting.nodes.edge_node_uv): as few as the raster
spacing asks for where the edge's curve on the surface is a straight line in (u, v), and, where it
bends, enough that the cubic the edge searches follow through them stays on the face's boundary
as OCC's curves on the surface define it."""
import numpy as np
import pytest
from support.boundary import boundary_distances
from support.faces import diagonal_band, holed_face, strip_face

from cmmsampling.fitting import nodes
from cmmsampling.geometry.surface import SurfaceModel


def edge_runs(face_nodes):
    """The (start, stop) index range of every edge's run of edge nodes, in order."""
    return sorted({tuple(run) for run in face_nodes.edge_runs})


def test_an_edge_straight_in_parameters_gets_the_nodes_its_length_and_the_raster_ask_for(reference):
    """The reference face's edges are its parameter rectangle's sides, each along 29 steps of a
    30 x 30 raster: each gets max(length / half a raster cell diagonal, 2 x 29) + 1 nodes (it had
    200 before, whatever its length)."""
    model = SurfaceModel.from_face(reference)
    found = nodes.face_nodes(model, 30)
    step = found.spacing / nodes.EDGE_NODES_PER_STEP
    expected = sorted(int(np.ceil(max(edge.Length / step, nodes.EDGE_NODES_PER_STEP * 29))) + 1
                      for edge in reference.Edges)
    counts = sorted(stop - start for start, stop in edge_runs(found))
    assert counts == expected
    assert max(counts) < nodes.EDGE_NODES_MOST


def test_a_narrow_strips_short_edges_get_as_many_nodes_as_the_raster_across_it():
    """On a 2 mm strip the raster's steps across the strip are far shorter than its cell
    diagonals: each short edge gets 2 nodes per raster step it crosses, as the long ones do (with
    nodes half a diagonal apart a short edge got 5, and the optimal layout's maximum was 1.2x
    its bound instead of 1.004x)."""
    face = strip_face()
    found = nodes.face_nodes(SurfaceModel.from_face(face), 30)
    assert sorted(stop - start for start, stop in edge_runs(found))[0] >= nodes.EDGE_NODES_PER_STEP * 29 + 1


def halfway_off(face):
    """mm, how far from the face's boundary as its curves on the surface define it
    (boundary_distances, OCC alone) the cubic through the face's edge nodes (edge_curve_uv) lies
    halfway between every two nodes of a run: (M,)."""
    model = SurfaceModel.from_face(face)
    found = nodes.face_nodes(model, 30)
    runs = found.edge_runs[:-1]
    inside = runs[:, 1] - np.arange(len(runs)) > 1
    place = np.flatnonzero(inside) + 0.5
    return boundary_distances(face, model.points(nodes.edge_curve_uv(found, place, runs[inside])[0]))


@pytest.mark.parametrize("make", [holed_face, diagonal_band], ids=["hole", "band"])
def test_the_cubic_through_a_bent_edges_nodes_stays_on_the_edge(make, monkeypatch):
    """Halfway between every two nodes of a trimming edge, the point the edge searches take for
    the edge lies within EDGE_CURVE_MM of the face's boundary; with only the nodes that the
    spacing and raster ask for it lies farther off."""
    face, tolerance = make(), nodes.EDGE_CURVE_MM
    assert halfway_off(face).max() <= tolerance * (1 + 1e-3)
    monkeypatch.setattr(nodes, "EDGE_CURVE_MM", np.inf)
    assert halfway_off(face).max() > 10 * tolerance
