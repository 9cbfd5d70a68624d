"""The sensors on the outline before a body calibration: each glyph is a box turned exactly as its
sensor's measured orientation in the scene, coloured by the sensor's state; the outline is one
calm grey and the skeleton's tints come back when it ends."""

from __future__ import annotations

import numpy as np
import pytest
from vtkmodules.vtkRenderingCore import vtkRenderer

from mimucap.core import rotation, skeleton
from mimucap.gui.scene.placed_copies import rgb_bytes
from mimucap.gui.scene.sensor_glyph_actor import SensorGlyphActor
from mimucap.gui.scene.skeleton_actor import OUTLINE_COLOUR, TINTS, SkeletonActor
from mimucap.session.views.skeleton_figure import GLYPH_SIZE_RATIO, R_SCENE_FROM_WORLD, FigureBuilder

WORN = {"S01": "pelvis", "S08": "thigh_r", "S10": "shank_r"}


def _outline(q_shank):
    builder = FigureBuilder(skeleton.load_model("ten_segment"), 1.75)
    q = {sensor: rotation.identity() for sensor in WORN}
    q["S10"] = q_shank
    return builder, builder.build_outline(q, WORN)


def test_a_glyphs_box_turns_with_its_sensors_orientation():
    renderer = vtkRenderer()
    glyphs = SensorGlyphActor(renderer)
    assert not glyphs.visible
    turns = [rotation.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(angle)) for angle in (0.0, 30.0, 75.0)]
    drawn = []
    for q in turns:
        _builder, geometry = _outline(q)
        glyphs.update(geometry.sensor_glyphs, {})
        assert glyphs.visible
        index = geometry.sensor_glyphs.sensor_ids.index("S10")
        matrix = geometry.sensor_glyphs.matrices[index]
        side = GLYPH_SIZE_RATIO * 1.75
        # The box's corners are exactly those of the unit cube placed by the sensor's rotation.
        local = np.linalg.solve(matrix[:3, :3], (glyphs.box_vertices("S10") - matrix[:3, 3]).T).T
        np.testing.assert_allclose(np.abs(local), 0.5, atol=1e-9)
        np.testing.assert_allclose(matrix[:3, :3], R_SCENE_FROM_WORLD @ rotation.to_matrix(q) * side, atol=1e-12)
        drawn.append(matrix[:3, 0] / side)  # the sensor's x axis in the scene
    # east (scene +x) turned counter-clockwise seen from above: towards north (scene −z)
    np.testing.assert_allclose(drawn[0], [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(drawn[1], [np.cos(np.radians(30)), 0.0, -np.sin(np.radians(30))], atol=1e-12)
    assert not np.allclose(drawn[1], drawn[2])
    glyphs.hide()
    assert not glyphs.visible
    glyphs.remove()
    assert renderer.GetActors().GetNumberOfItems() == 0


def test_a_glyph_is_coloured_by_its_sensors_state():
    glyphs = SensorGlyphActor(vtkRenderer())
    _builder, geometry = _outline(rotation.identity())
    glyphs.update(geometry.sensor_glyphs, {"thigh_r": "stale", "pelvis": "ok"})
    assert (glyphs.tint_of("S08"), glyphs.tint_of("S01"), glyphs.tint_of("S10")) == ("stale", "ok", "no_sensor")
    box = glyphs._copies.vertex_range(4 * geometry.sensor_glyphs.sensor_ids.index("S08"))
    assert np.all(glyphs._colours[box] == rgb_bytes(TINTS["stale"]))
    with pytest.raises(ValueError, match="unknown sensor state"):
        glyphs.update(geometry.sensor_glyphs, {"thigh_r": "asleep"})


def test_the_outline_is_grey_and_the_tints_come_back_after_it():
    builder, geometry = _outline(rotation.identity())
    figure = SkeletonActor(vtkRenderer(), builder)
    figure.set_tints({"thigh_r": "stale"})
    assert figure.set_outline(True) and not figure.set_outline(True)
    figure.update(geometry)
    assert np.all(figure._colours == rgb_bytes(OUTLINE_COLOUR))
    figure.set_tints({"thigh_r": "ok"})
    assert np.all(figure._colours == rgb_bytes(OUTLINE_COLOUR))  # the outline keeps its grey
    figure.set_outline(False)
    thigh = figure._segments.vertex_range(builder.segment_names.index("thigh_r"))
    assert figure.tint_of("thigh_r") == "ok" and np.all(figure._colours[thigh] == rgb_bytes(TINTS["ok"]))
