"""Deviation colours (blue, cyan, green, yellow, red from 0 to the maximum) and their legend.

The legend is a coin3d overlay drawn at the 3D view's side, like the Inspection workbench's
colour bar: a column of colour bands with tick labels in mm, each text on a light box that keeps
it readable over the part; a substitute's at the left, an inspection's at the right, so the two
never overlap. Keys (a swatch and its meaning, e.g. the shade of what a probe cannot
reach) are overlays of the same kind below it.
"""
import FreeCADGui
import numpy as np
from pivy import coin
from PySide import QtGui

STOPS = np.array([
    [0.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [0.0, 1.0, 0.0],
    [1.0, 1.0, 0.0],
    [1.0, 0.0, 0.0],
])
OFF_FACE = (0.6, 0.6, 0.6)
LEGEND_BANDS = 40
LEGEND_TICKS = 5
# The legend sits at the left, clear of the navigation cube (top right) and the axis cross
# (bottom right); x and y in the view's [-1, 1] square.
LEGEND_X = (-0.97, -0.93)
LEGEND_Y = (-0.7, 0.4)
# A legend at the right (an inspection's, apart from a substitute's at the left) ends here, below
# the navigation cube and above the axis cross; a title's lines are TITLE_LINE apart (view units).
RIGHT_EDGE = 0.97
TITLE_LINE = 0.06
# Deviations below this (mm) are shown in one colour: finer than any CMM measures, so a
# spread of colours there would be rounding noise.
SMALLEST_SHOWN_MM = 1e-4
TEXT_COLOUR = (0.0, 0.0, 0.0)
FONT_SIZE = 14
# The backdrop behind the legend's and keys' texts: colour and transparency; a swatch's height
# (view units). A text box is as wide as its text in Qt's metrics of the font, TEXT_ALLOWANCE
# wider (Coin draws the font with its own renderer), over the 3D view's width (DEFAULT_VIEW_PX
# where there is no view).
BACKDROP_COLOUR = (1.0, 1.0, 1.0)
BACKDROP_TRANSPARENCY = 0.25
SWATCH_HEIGHT = 0.03
TEXT_ALLOWANCE = 1.1
DEFAULT_VIEW_PX = 1000
# A text's box reaches this far below and above its position, and beyond its ends (view units:
# less than the gap between a colour bar or swatch and its text).
TEXT_BELOW = 0.015
TEXT_ABOVE = 0.045
TEXT_MARGIN = 0.008
# Keys sit below the legend, one KEY_HEIGHT apart (view units).
KEY_Y = -0.8
KEY_HEIGHT = 0.07


def colours(values, maximum):
    """RGB in [0, 1] for deviations: values (...) mm -> (..., 3), NaN -> grey.

    0 maps to blue and ``maximum`` (mm, > 0) to red, linearly through cyan, green and yellow.
    """
    values = np.asarray(values, dtype=float)
    scaled = np.clip(np.nan_to_num(values / maximum if maximum > 0 else values * 0), 0, 1)
    position = scaled * (len(STOPS) - 1)
    low = np.minimum(position.astype(int), len(STOPS) - 2)
    weight = (position - low)[..., None]
    rgb = STOPS[low] * (1 - weight) + STOPS[low + 1] * weight
    rgb[np.isnan(values)] = OFF_FACE
    return rgb


def shown_maximum(maximum):
    """The deviation (mm) shown red: the largest one, at least SMALLEST_SHOWN_MM."""
    return max(float(maximum), SMALLEST_SHOWN_MM)


def tick_labels(maximum, count=LEGEND_TICKS):
    """count labels from 0 to maximum mm, always in mm, with four significant digits at the top,
    e.g. ['0.0000 mm', ..., '1.053 mm'] or ['0.000000 mm', ..., '0.005710 mm']."""
    digits = max(0, 3 - int(np.floor(np.log10(maximum)))) if maximum > 0 else 3
    return [f"{value:.{digits}f} mm" for value in np.linspace(0, maximum, count)]


def legend(maximum, title="Deviation", right=False):
    """A screen overlay (see :func:`overlay`) with the colour bar from 0 to ``maximum`` mm, its
    tick labels and title, each text on a light box of its own: at the left, or (right) at the
    view's right edge, where an inspection's legend goes, apart from a substitute's."""
    heights = np.linspace(*LEGEND_Y, LEGEND_TICKS)
    texts = [(text, (LEGEND_X[1] + 0.01, float(y) - 0.015)) for text, y in zip(tick_labels(maximum), heights)]
    texts.append((title, (LEGEND_X[0], LEGEND_Y[1] + 0.05)))
    written, far = _written(texts)
    return overlay(_placed([_bar(maximum), *written], far, right))


def band_legend(rows, title, right=False):
    """A screen overlay (see :func:`overlay`) listing colour bands: rows [(rgb, text)] from the
    top down, each a swatch and its text, the title's lines (a text, or a list of them, the
    first on top) above, each on a light box of its own (e.g. the bands of a tolerance zone); at
    the legend's place at the left, or (right) at the view's right edge."""
    lines = [title] if isinstance(title, str) else list(title)
    x0, x1 = LEGEND_X
    top = LEGEND_Y[1] - TITLE_LINE * (len(lines) - 1)
    children, texts = [], []
    for row, (rgb, text) in enumerate(rows):
        y = top - KEY_HEIGHT * (row + 1)
        children.append(_rectangle((x0, y), (x1, y + SWATCH_HEIGHT), rgb, 0.0))
        texts.append((text, (x1 + 0.01, y + 0.005)))
    texts += [(line, (x0, top + 0.05 + TITLE_LINE * (len(lines) - 1 - row))) for row, line in enumerate(lines)]
    written, far = _written(texts)
    return overlay(_placed(children + written, far, right))


def key(rgb, text, row=0):
    """A screen overlay (see :func:`overlay`) below the legend: a swatch of colour ``rgb`` and
    ``text`` beside it on a light box; row 0, 1, ... stacks keys downwards."""
    y = KEY_Y - row * KEY_HEIGHT
    x0, x1 = LEGEND_X
    swatch = _rectangle((x0, y), (x1, y + SWATCH_HEIGHT), rgb, 0.0)
    return overlay([swatch, *_written([(text, (x1 + 0.01, y + 0.005))])[0]])


def _written(texts):
    """Texts [(text, (x, y))] at their places (view units), each on a light box (the backdrop)
    that keeps it readable over the part and covers no more of it than the text: (the nodes,
    the x where the farthest box ends)."""
    ends = [x + text_width(text) + TEXT_MARGIN for text, (x, _) in texts]
    boxes = [_backdrop((x - TEXT_MARGIN, y - TEXT_BELOW), (end, y + TEXT_ABOVE))
             for (_, (x, y)), end in zip(texts, ends)]
    labels = text_node(TEXT_COLOUR, FONT_SIZE)
    for text, (x, y) in texts:
        labels.addChild(text_at(text, (x, y, 0.0)))
    return [*boxes, labels], max(ends)


def _placed(children, far, right):
    """A legend's children (drawn from the left edge, reaching x = far), moved so that they end
    at the view's right edge (RIGHT_EDGE) when ``right``."""
    if not right:
        return children
    move = coin.SoTranslation()
    move.translation = (RIGHT_EDGE - far, 0.0, 0.0)
    return [move, *children]


def text_width(text):
    """The width of ``text`` at FONT_SIZE in the view's units (2 across the view)."""
    font = QtGui.QFont("Sans")
    font.setPixelSize(FONT_SIZE)
    pixels = QtGui.QFontMetrics(font).horizontalAdvance(text)
    return 2.0 * TEXT_ALLOWANCE * pixels / view_width()


def view_width():
    """The width in pixels of FreeCAD's central area, where its 3D views are (DEFAULT_VIEW_PX
    without one). The area lives as long as the main window: a Python wrapper of a view, which
    closes with its document, could be handed out again by PySide for another widget made at the
    same address (see cmmsampling.gui.qt_compat.forget_when_destroyed)."""
    window = FreeCADGui.getMainWindow()
    area = window.findChild(QtGui.QMdiArea) if window is not None else None
    width = area.width() if area is not None else 0
    return width if width > 0 else DEFAULT_VIEW_PX


def overlay(children):
    """A coin SoAnnotation drawing ``children`` in the view's [-1, 1] square, on top of the scene.

    It has its own orthographic camera, is not lit, not pickable and does not count in the
    scene's bounding box (so "fit all" ignores it).
    """
    node = coin.SoAnnotation()
    skip = coin.SoType.fromName("SoSkipBoundingGroup").createInstance()
    node.addChild(skip)
    camera = coin.SoOrthographicCamera()
    camera.viewportMapping = coin.SoCamera.LEAVE_ALONE
    camera.position = (0, 0, 5)
    camera.height = 2
    camera.nearDistance = 1
    camera.farDistance = 10
    pick = coin.SoPickStyle()
    pick.style = coin.SoPickStyle.UNPICKABLE
    light = coin.SoLightModel()
    light.model = coin.SoLightModel.BASE_COLOR
    for child in (pick, camera, light, *children):
        skip.addChild(child)
    return node


def _backdrop(corner, far):
    """The light, half-transparent rectangle behind a legend or key, from corner (x, y) to far."""
    return _rectangle(corner, far, BACKDROP_COLOUR, BACKDROP_TRANSPARENCY, depth=-0.1)


def _rectangle(corner, far, rgb, transparency, depth=0.0):
    """A flat rectangle of colour rgb in view units from corner (x, y) to far (x, y)."""
    (x0, y0), (x1, y1) = corner, far
    node = coin.SoSeparator()
    material = coin.SoMaterial()
    material.diffuseColor = rgb
    material.transparency = transparency
    coordinates = coin.SoCoordinate3()
    coordinates.point.setValues(0, 4, [(x0, y0, depth), (x1, y0, depth), (x1, y1, depth), (x0, y1, depth)])
    faces = coin.SoFaceSet()
    faces.numVertices.setValue(4)
    for child in (material, coordinates, faces):
        node.addChild(child)
    return node


def _bar(maximum):
    """The colour bands: LEGEND_BANDS quads between LEGEND_Y, coloured at their corners."""
    x0, x1 = LEGEND_X
    heights = np.linspace(*LEGEND_Y, LEGEND_BANDS + 1)
    coords = [(x, y, 0.0) for y in heights for x in (x0, x1)]
    rgb = colours(np.repeat(np.linspace(0, maximum, LEGEND_BANDS + 1), 2), maximum)
    index = []
    for band in range(LEGEND_BANDS):
        a = 2 * band
        index += [a, a + 1, a + 3, a + 2, -1]
    node = coin.SoSeparator()
    material = coin.SoMaterial()
    material.diffuseColor.setValues(0, len(rgb), [tuple(map(float, c)) for c in rgb])
    binding = coin.SoMaterialBinding()
    binding.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
    coordinates = coin.SoCoordinate3()
    coordinates.point.setValues(0, len(coords), coords)
    faces = coin.SoIndexedFaceSet()
    faces.coordIndex.setValues(0, len(index), index)
    faces.materialIndex.setValues(0, len(index), index)
    for child in (material, binding, coordinates, faces):
        node.addChild(child)
    return node


def text_node(rgb, size):
    """A separator whose text children are drawn in colour ``rgb`` with the Sans font, ``size``
    pixels."""
    node = coin.SoSeparator()
    colour = coin.SoBaseColor()
    colour.rgb = rgb
    font = coin.SoFont()
    font.name = "Sans"
    font.size = size
    node.addChild(colour)
    node.addChild(font)
    return node


def text_at(text, position):
    """A separator with screen-aligned text (SoText2) at position (x, y, z)."""
    node = coin.SoSeparator()
    move = coin.SoTranslation()
    move.translation = position
    label = coin.SoText2()
    label.string = text
    node.addChild(move)
    node.addChild(label)
    return node
