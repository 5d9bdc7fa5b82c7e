"""How the colour attribute stores the bake (Advanced > Colour Attribute, or --color-type,
--color-domain, --exposure, --tone): 8-bit sRGB with exposure and a tone curve, per vertex."""

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object, light_object

# A grey floor (rho 0.5) under a sun of irradiance 2 W/m^2: radiosity rho E / pi everywhere.
RADIOSITY = 0.5 * 2.0 / np.pi


def srgb(linear: float) -> float:
    """The sRGB transfer function (IEC 61966-2-1)."""
    return 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055


def lit_floor():
    floor = grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    return floor


def stored_srgb(obj) -> np.ndarray:
    layer = obj.data.color_attributes["Radiosity"]
    assert layer.data_type == "BYTE_COLOR"
    values = np.empty(len(layer.data) * 4, dtype=np.float32)
    layer.data.foreach_get("color_srgb", values)
    return values.reshape(-1, 4)[:, :3]


@pytest.mark.parametrize("exposure, tone, expected", [
    (0.0, "CLIP", RADIOSITY),
    (1.0, "CLIP", 2 * RADIOSITY),
    (3.0, "CLIP", 1.0),  # 2.55 clipped
    (3.0, "SOFT", 8 * RADIOSITY * (1 + 8 * RADIOSITY / 16) / (1 + 8 * RADIOSITY)),
])
def test_byte_colours_are_srgb_bytes_of_the_exposed_toned_radiosity(exposure, tone, expected):
    floor = lit_floor()
    settings = bpy.context.scene.radiosity
    settings.color_type, settings.exposure, settings.tone = "BYTE_COLOR", exposure, tone
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    assert np.allclose(stored_srgb(floor), srgb(expected), atol=0.6 / 255)  # one byte's rounding


def test_vertex_colours_are_the_means_of_the_corner_colours():
    """A box corner (three faces at right angles, each its own colour at the shared vertices):
    per vertex, the mean of the corner colours a Face Corner bake gives."""
    grey = diffuse_material("Grey", (0.5, 0.5, 0.5))
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    box = bpy.context.active_object
    box.data.materials.append(grey)
    light_object("Lamp", "POINT", (3.0, -2.0, 4.0), 500.0)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    _, corners = corner_colours(box)
    loop_vertex = np.empty(len(box.data.loops), dtype=np.int32)
    box.data.loops.foreach_get("vertex_index", loop_vertex)
    expected = np.array([corners[loop_vertex == v, :3].mean(axis=0) for v in range(len(box.data.vertices))])
    assert max(np.ptp(corners[loop_vertex == v, 0]) for v in range(8)) > 0.05  # the corners at a vertex differ
    bpy.context.scene.radiosity.color_domain = "POINT"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    layer = box.data.color_attributes["Radiosity"]
    assert (layer.domain, layer.data_type) == ("POINT", "FLOAT_COLOR")
    values = np.empty(len(layer.data) * 4, dtype=np.float32)
    layer.data.foreach_get("color", values)
    assert np.allclose(values.reshape(-1, 4)[:, :3], expected, rtol=1e-6, atol=1e-7)


def test_storage_options_on_the_command_line(addon, tmp_path):
    lit_floor()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    output = str(tmp_path / "baked.blend")
    argv = ["--output", output, "-q", "--color-type", "byte_color", "--color-domain", "point", "--exposure", "1",
            "--tone", "soft"]
    assert addon.radiosity_addon.cli.main(argv) == 0
    bpy.ops.wm.open_mainfile(filepath=output)
    settings = bpy.context.scene.radiosity
    assert (settings.color_type, settings.color_domain, settings.exposure, settings.tone) == (
        "BYTE_COLOR", "POINT", 1.0, "SOFT")
    layer = bpy.data.objects["Floor"].data.color_attributes["Radiosity"]
    assert (layer.domain, layer.data_type) == ("POINT", "BYTE_COLOR")


def test_direct_and_indirect_attributes_add_up_to_the_bake():
    """A floor under a sun beside a white wall (not touching it): the floor's direct light is the
    sun's (rho E / pi: the wall shades none of it), the wall's light on it is indirect, and the
    two attributes add up to the bake's."""
    floor = lit_floor()
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(1.25, 0.0, 1.0), rotation=(0.0, -np.pi / 2, 0.0))
    bpy.context.active_object.data.materials.append(diffuse_material("White", (0.8, 0.8, 0.8)))
    bpy.context.scene.radiosity.separate_direct = True
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    _, total = corner_colours(floor)
    _, direct = corner_colours(floor, "Radiosity Direct")
    _, indirect = corner_colours(floor, "Radiosity Indirect")
    np.testing.assert_allclose(direct[:, :3] + indirect[:, :3], total[:, :3], rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(direct[:, :3], RADIOSITY, rtol=1e-3)  # the sun is straight above: no shade
    assert indirect[:, :3].max() > 0.01 and floor.data.color_attributes.active_color.name == "Radiosity"
