"""Point labels that keep apart on screen at any zoom.

The labels of a set of points are thinned at a ladder of spacings (mm), each level a greedy
subset of the labels at least that far apart. Coin picks the level as it renders (an
SoLevelOfDetail on the size on screen of a box all levels share): the level whose spacing
spans the labels' gap (:func:`label_gap`) at the present zoom. Zooming in shows more labels, zooming
out fewer, and a view of the whole part shows none closer than the gap.
"""
import numpy as np
from pivy import coin
from PySide import QtGui
from scipy.spatial import cKDTree

from ..strategies.blind import spaced
from . import colormap

# Labels drawn at one level keep at least this many pixels apart on screen, and twice the width
# of the widest label (a plan's "Face289_P12" is four times as wide as "P12"): seen at a slant,
# points come closer on screen than their spacing (half as close on a face seen isometric).
LABEL_GAP_PX = 60.0
# The ladder of spacings: span/r, span/r^2, ... (span: the shared box's diagonal, mm; r the
# ratio), this many: down to span/512, a level at most 1.4 times as sparse as the zoom allows.
LABEL_RATIO = np.sqrt(2.0)
LABEL_LEVELS = 18
# The area on screen of the cube the levels are picked on (points_box), as a share of its
# diagonal squared (mm^2), taken to tell how many pixels a millimetre spans: seen along an axis
# the cube covers a third, from a corner nearly all of it.
PROJECTED_SHARE = 0.5


def spacings(span, floor):
    """The ladder of label spacings (mm), finest first: ``floor`` (mm: the view's LabelSpacing;
    0 puts every label on the finest level), then span/r^k above it (r: LABEL_RATIO)."""
    ladder = [span / LABEL_RATIO ** k for k in range(LABEL_LEVELS, 0, -1) if span / LABEL_RATIO ** k > floor]
    return [float(floor)] + ladder


def label_gap(labels, size):
    """The gap (pixels) labels keep on screen: LABEL_GAP_PX, or twice the widest of ``labels``
    in Sans at ``size`` pixels."""
    font = QtGui.QFont("Sans")
    font.setPixelSize(size)
    metrics = QtGui.QFontMetrics(font)
    return max([LABEL_GAP_PX] + [2.0 * metrics.horizontalAdvance(label) for label in labels])


def screen_areas(span, ladder, gap):
    """Coin's screenArea thresholds (pixels^2) for the levels of ``ladder`` (mm, finest first):
    a level is drawn while the shared box covers more than its threshold, the size at which its
    spacing spans ``gap`` pixels on screen. The finest level of spacing 0 (all labels) has the
    threshold of a level one step finer than its neighbour."""
    finest = ladder[0] if ladder[0] > 0 else (ladder[1] if len(ladder) > 1 else span) / LABEL_RATIO
    pixels_per_mm = gap / np.array([finest] + list(ladder[1:]))
    return (pixels_per_mm ** 2 * PROJECTED_SHARE * span ** 2).tolist()


def level_subsets(tips, ladder, taken=None, kept=None):
    """Per level of ``ladder`` (mm, finest first) the indices of tips (N, 3) mm whose labels it
    draws: a greedy subset at least its spacing apart, and as far from ``taken[k]`` (M, 3) mm,
    labels another object draws at level k, and from the positions ``kept`` (K, 3) mm (other
    marks, e.g. a max label, which keep twice the spacing)."""
    levels = []
    for k, spacing in enumerate(ladder):
        free = np.arange(len(tips))
        blocked = [(np.asarray(taken[k]), spacing)] if taken and k < len(taken) and len(taken[k]) else []
        if kept is not None and len(kept):
            blocked.append((np.asarray(kept), 2.0 * spacing))
        for positions, distance in blocked:
            if distance > 0 and free.size:
                gaps = cKDTree(positions).query(tips[free], distance_upper_bound=distance)[0]
                free = free[gaps >= distance]
        levels.append(free[spaced(tips[free], spacing)])
    return levels


def labelled_levels(labels, tips, levels, box, areas, size, colour):
    """The labels as a Coin level-of-detail node: one child per level (labels[i] at tips[i] for
    i in levels[k]; tips (N, 3) mm), then an empty one for a view too small for any; every
    child spans ``box`` ((2, 3) mm, by invisible points at its corners) so that all objects
    sharing the box pick the same level; areas: the levels' screen-area thresholds (pixels^2);
    size: the font's pixels; colour: rgb 0..1."""
    lod = coin.SoLevelOfDetail()
    lod.screenArea.setValues(0, len(areas), [float(a) for a in areas])
    corners = box_corners(box)
    nodes = {}
    for shown in levels + [[]]:
        child = coin.SoSeparator()
        text = colormap.text_node(colour, size)
        for i in shown:
            if i not in nodes:   # one node per label, shared by the levels that draw it
                nodes[i] = colormap.text_at(labels[i], tuple(map(float, tips[i])))
            text.addChild(nodes[i])
        child.addChild(text)
        child.addChild(box_only())
        child.addChild(corners)
        lod.addChild(child)
    node = coin.SoAnnotation()
    complexity = coin.SoComplexity()   # the level follows the size on screen alone
    complexity.type = coin.SoComplexity.OBJECT_SPACE
    complexity.value = 0.5
    node.addChild(complexity)
    node.addChild(lod)
    return node


def box_only():
    """A reset of the bounding box gathered so far (in the separator it lies in; drawing is not
    touched): a level-of-detail child that then ends with :func:`box_corners` spans the box
    alone (the labels' boxes, which grow in millimetres as the view zooms out, would otherwise
    hold the level back)."""
    reset = coin.SoResetTransform()
    reset.whatToReset = coin.SoResetTransform.BBOX
    return reset


def box_corners(box):
    """Invisible points at the corners of box ((2, 3) mm): they give a level-of-detail child
    the box's size on screen, and draw nothing."""
    node = coin.SoSeparator()
    style = coin.SoDrawStyle()
    style.style = coin.SoDrawStyle.INVISIBLE
    coords = coin.SoCoordinate3()
    corners = [(box[i][0], box[j][1], box[k][2]) for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    coords.point.setValues(0, 8, [tuple(map(float, corner)) for corner in corners])
    points = coin.SoPointSet()
    for child in (style, coords, points):
        node.addChild(child)
    return node


def decluttered(labels, tips, size, colour, floor=0.0, box=None, taken=None, kept=None):
    """Labels ``labels`` (N strings) at tips (N, 3) mm that keep apart on screen at any zoom:
    (the Coin node, the ladder of spacings mm finest first, each level's indices). floor: the
    least spacing, mm; box: the (2, 3) mm box the level is picked on (default the tips', at
    least 1 mm across); taken, kept: as :func:`level_subsets` takes them."""
    box = points_box(tips) if box is None else box
    span = float(np.linalg.norm(box[1] - box[0]))
    ladder = spacings(span, floor)
    levels = level_subsets(tips, ladder, taken, kept)
    node = labelled_levels(labels, tips, levels, box, screen_areas(span, ladder, label_gap(labels, size)), size,
                           colour)
    return node, ladder, levels


def points_box(points):
    """The cube (2, 3) mm the levels are picked on: centred on the box of points (N, 3) mm,
    with that box's diagonal (at least 1 mm). A cube covers about the same area on screen from
    any direction (a long strip's box does not: seen along it, it covers nearly nothing), and it
    lies within the sphere a fitted view shows."""
    low, high = points.min(axis=0), points.max(axis=0)
    half = max(float(np.linalg.norm(high - low)), 1.0) / (2.0 * np.sqrt(3.0))
    middle = (low + high) / 2.0
    return np.array([middle - half, middle + half])
