"""Deviation colours (blue, cyan, green, yellow, red from 0 to the maximum) and their legend.

The legend is a coin3d overlay drawn in the 3D view's corner, like the Inspection workbench's
colour bar: a column of colour bands with tick labels in mm, on a light backdrop that keeps it
readable over the part. Keys (a swatch and its meaning, e.g. the shade of what a probe cannot
reach) are overlays of the same kind below it.
"""
import numpy as np
from pivy import coin

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
# Deviations below this (mm) are shown in one colour: finer than any CMM measures, so a
# spread of colours there would be rounding noise.
SMALLEST_SHOWN_MM = 1e-4
TEXT_COLOUR = (0.0, 0.0, 0.0)
FONT_SIZE = 14
# The backdrop behind the legend and the keys: colour, transparency, margin (view units) and the
# width a character of FONT_SIZE takes in view units (for a view about 1000 pixels across).
BACKDROP_COLOUR = (1.0, 1.0, 1.0)
BACKDROP_TRANSPARENCY = 0.25
BACKDROP_MARGIN = 0.02
CHARACTER_WIDTH = 0.017
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


def legend(maximum, title="Deviation"):
    """A screen overlay (see :func:`overlay`) with the colour bar from 0 to ``maximum`` mm at the
    left, its tick labels and title on a light backdrop."""
    labels = tick_labels(maximum)
    width = LEGEND_X[1] - LEGEND_X[0] + 0.01 + CHARACTER_WIDTH * max(len(text) for text in labels)
    width = max(width, CHARACTER_WIDTH * len(title))
    corner = (LEGEND_X[0] - BACKDROP_MARGIN, LEGEND_Y[0] - 0.05)
    top = LEGEND_Y[1] + 0.05 + KEY_HEIGHT
    backdrop = _backdrop(corner, (corner[0] + width + 2 * BACKDROP_MARGIN, top))
    return overlay([backdrop, _bar(maximum), _labels(labels, title)])


def band_legend(rows, title):
    """A screen overlay (see :func:`overlay`) listing colour bands at the legend's place: rows
    [(rgb, text)] from the top down, each a swatch and its text, the title above, on a light
    backdrop (e.g. the bands of a tolerance zone)."""
    x0, x1 = LEGEND_X
    top = LEGEND_Y[1]
    width = max([x1 - x0 + 0.01 + CHARACTER_WIDTH * len(text) for _, text in rows] + [CHARACTER_WIDTH * len(title)])
    bottom = top - KEY_HEIGHT * len(rows)
    corner = (x0 - BACKDROP_MARGIN, bottom - BACKDROP_MARGIN)
    children = [_backdrop(corner, (x0 + width + BACKDROP_MARGIN, top + 0.05 + KEY_HEIGHT))]
    labels = text_node(TEXT_COLOUR, FONT_SIZE)
    for row, (rgb, text) in enumerate(rows):
        y = top - KEY_HEIGHT * (row + 1)
        children.append(_rectangle((x0, y), (x1, y + KEY_HEIGHT - 2 * BACKDROP_MARGIN), rgb, 0.0))
        labels.addChild(text_at(text, (x1 + 0.01, y + 0.005, 0.0)))
    labels.addChild(text_at(title, (x0, top + 0.05, 0.0)))
    return overlay(children + [labels])


def key(rgb, text, row=0):
    """A screen overlay (see :func:`overlay`) below the legend: a swatch of colour ``rgb`` and
    ``text`` beside it on a light backdrop; row 0, 1, ... stacks keys downwards."""
    y = KEY_Y - row * KEY_HEIGHT
    x0, x1 = LEGEND_X
    corner = (x0 - BACKDROP_MARGIN, y - BACKDROP_MARGIN)
    far = (x1 + 0.01 + CHARACTER_WIDTH * len(text) + BACKDROP_MARGIN, y + KEY_HEIGHT - BACKDROP_MARGIN)
    swatch = _rectangle((x0, y), (x1, y + KEY_HEIGHT - 2 * BACKDROP_MARGIN), rgb, 0.0)
    label = text_node(TEXT_COLOUR, FONT_SIZE)
    label.addChild(text_at(text, (x1 + 0.01, y + 0.005, 0.0)))
    return overlay([_backdrop(corner, far), swatch, label])


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


def _labels(labels, title):
    """Tick labels (LEGEND_TICKS texts, bottom up) right of the bar and the title above it, as
    screen-aligned text."""
    node = text_node(TEXT_COLOUR, FONT_SIZE)
    heights = np.linspace(*LEGEND_Y, LEGEND_TICKS)
    for text, y in zip(labels, heights):
        node.addChild(text_at(text, (LEGEND_X[1] + 0.01, float(y) - 0.015, 0.0)))
    node.addChild(text_at(title, (LEGEND_X[0], LEGEND_Y[1] + 0.05, 0.0)))
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
