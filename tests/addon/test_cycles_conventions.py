"""Each light type, emissive meshes and the world colour, read from real Blender data and baked
through the operator, against Cycles' conventions (shared/CYCLES.md, measured with Blender
5.0.1; ratios 1.0000 +- 0.0008):

    emission colour c, strength S          S c
    point, power P                         rho P cos / (4 pi^2 r^2)
    point of radius R, Soft Falloff        rho P cos / (4 pi^2 (r^2 + R^2))  (a Cycles render:
                                           0.998 to 1.0005 at R = 0.4 m, 0.5 m up)
    spot                                   the same inside the cone (times Cycles' blend)
    sun, strength E                        rho E cos / pi
    area, power P, area A                  rho P / (pi A) F(point -> light)
    area of Spread s                       the same, F weighted by max(tan(s/2) - tan a, 0) /
                                           (tan(s/2) - s/2) (a Cycles render: 0.997 to 1.004 at
                                           90 degrees, 1 m under a 1 m light)
    world colour C, strength k             rho C k on an open upward plane
    an area light marked Portal            no light
    a light or world invisible to diffuse  no light
    Cast Shadow off                        the light's own formula under a roof

The floor cannot see itself, so it shows direct light only and the formulas are exact. Colours
are evaluated NODE_INSET = 4e-5 of the scene's extent into each vertex's faces; on these scenes of a
few metres that moves a point by a fraction of a millimetre and its value by under 2e-3 (the
tolerance, well inside the 1 % asked).
"""

import math

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import (
    bake_in_background, corner_colours, diffuse_material, emission_material, grid_object, light_object, world_colour,
)
from tests.core.test_form_factor_closed_forms import b3_anywhere, b12

RHO = np.array([0.5, 0.4, 0.3])
RTOL = 2e-3
EXACT = 1e-6  # colour attributes store float32: 6e-8 relative, plus the sums in float64


@pytest.fixture
def floor():
    """A 4 m x 4 m floor of 8 x 8 quads at z = 0, facing up, diffuse of reflectance RHO."""
    return grid_object("Floor", material=diffuse_material("Floor", RHO))


def baked(obj) -> tuple[np.ndarray, np.ndarray]:
    assert bake_in_background() == {"FINISHED"}
    points, colours = corner_colours(obj)
    np.testing.assert_array_equal(colours[:, 3], 1.0)
    return points, colours[:, :3]


def test_emissive_surface_bakes_to_strength_times_colour():
    colour, strength = np.array([0.2, 0.5, 1.0]), 3.0
    panel = grid_object("Panel", 1.0, 2, material=emission_material("Glow", colour, strength))
    _, colours = baked(panel)
    np.testing.assert_allclose(colours, np.tile(strength * colour, (len(colours), 1)), rtol=EXACT)


def test_emission_shines_from_both_sides_of_a_mesh(floor):
    """A 1 m square emitter at 1 m facing up (away from the floor) still lights it, as in Cycles."""
    grid_object("Panel", 1.0, 1, location=(0, 0, 1), material=emission_material("Glow", (1, 1, 1), 2.0))
    points, colours = baked(floor)
    centre = np.linalg.norm(points[:, :2], axis=1) < 1e-9
    np.testing.assert_allclose(colours[centre], np.tile(RHO * 2.0 * b3_anywhere(0, 0, -.5, .5, -.5, .5, 1.0),
                                                        (centre.sum(), 1)), rtol=RTOL)


def test_point_light(floor):
    lamp = light_object("Lamp", "POINT", (0.3, -0.2, 1.5), 100.0, colour=(1.0, 0.5, 0.2), shadow_soft_size=0.0)
    points, colours = baked(floor)
    offset = np.array(lamp.location) - points
    r2 = (offset**2).sum(axis=1)
    expected = RHO * 100.0 * np.array(lamp.data.color) * (offset[:, 2] / np.sqrt(r2) / (4 * math.pi**2 * r2))[:, None]
    np.testing.assert_allclose(colours, expected, rtol=RTOL)


@pytest.mark.parametrize("soft_falloff", [True, False])
def test_a_point_light_of_a_radius_with_and_without_soft_falloff(floor, soft_falloff):
    """Soft Falloff (Blender 4.0+, on by default): Cycles lights by a disc of the light's radius
    facing each point, dimmer near the light; off, by a sphere, as its centre. Measured by a
    Cycles render of this floor (Standard view, EXR) at R = 0.4 m, 0.5 m up: each formula within
    0.2 %, the other 35 % off under the light."""
    radius, height = 0.4, 0.5
    lamp = light_object("Lamp", "POINT", (0.0, 0.0, height), 100.0, shadow_soft_size=radius,
                        use_soft_falloff=soft_falloff)
    points, colours = baked(floor)
    offset = np.array(lamp.location) - points
    r2 = (offset**2).sum(axis=1)
    spread = r2 + (radius**2 if soft_falloff else 0.0)
    expected = RHO * 100.0 * (offset[:, 2] / np.sqrt(r2) / (4 * math.pi**2 * spread))[:, None]
    np.testing.assert_allclose(colours, expected, rtol=RTOL)


def test_a_lights_colour_takes_its_temperature_and_its_emission_node(floor):
    """Cycles multiplies a light's power by its colour, its blackbody colour (where this Blender
    has one) and its Emission node's colour x strength (checked by Cycles renders: 0.998 to 1.001
    of that product in every channel, docs/notes/experiments.md, "A light's colour")."""
    lamp = light_object("Lamp", "POINT", (0.3, -0.2, 1.5), 100.0, colour=(1.0, 0.8, 0.6))
    lamp.data.use_nodes = True
    emission = next(node for node in lamp.data.node_tree.nodes if node.bl_idname == "ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    emission.inputs["Strength"].default_value = 2.0
    colour = np.array([1.0, 0.8, 0.6]) * np.array([2.0, 1.0, 0.5])
    if hasattr(lamp.data, "use_temperature"):
        lamp.data.use_temperature, lamp.data.temperature = True, 3000.0
        colour = colour * np.array(lamp.data.temperature_color)
    points, colours = baked(floor)
    offset = np.array(lamp.location) - points
    r2 = (offset**2).sum(axis=1)
    expected = RHO * 100.0 * colour * (offset[:, 2] / np.sqrt(r2) / (4 * math.pi**2 * r2))[:, None]
    np.testing.assert_allclose(colours, expected, rtol=RTOL)


def test_spot_light_inside_its_cone_and_beyond(floor):
    spot = light_object("Spot", "SPOT", (0.0, 0.0, 1.0), 200.0, spot_size=math.radians(90), spot_blend=0.3,
                        shadow_soft_size=0.0)
    points, colours = baked(floor)
    offset = np.array(spot.location) - points
    distance = np.linalg.norm(offset, axis=1)
    cosine = offset[:, 2] / distance
    cos_half = math.cos(spot.data.spot_size / 2)
    t = np.clip((cosine - cos_half) / ((1 - cos_half) * spot.data.spot_blend), 0, 1)
    mask = t * t * (3 - 2 * t)
    assert (mask == 1).sum() > 10 and (mask == 0).sum() > 10
    expected = RHO * (200.0 * mask * cosine / (4 * math.pi**2 * distance**2))[:, None]
    np.testing.assert_allclose(colours, expected, rtol=RTOL, atol=1e-4)


def test_sun_light(floor):
    sun = light_object("Sun", "SUN", (0, 0, 5), 3.0, rotation=(0.4, 0.2, 0.0))
    bpy.context.view_layer.update()
    direction = -np.array(sun.matrix_world)[:3, 2]
    points, colours = baked(floor)
    np.testing.assert_allclose(colours, np.tile(RHO * 3.0 * -direction[2] / math.pi, (len(colours), 1)), rtol=EXACT)


@pytest.mark.parametrize("shape", ["SQUARE", "RECTANGLE"])
def test_area_light(floor, shape):
    size_y = 0.5 if shape == "RECTANGLE" else 1.0
    light_object("Area", "AREA", (0.2, 0.1, 1.2), 30.0, shape=shape, size=1.0, size_y=size_y)
    points, colours = baked(floor)
    radiance = 30.0 / (math.pi * 1.0 * size_y)
    factors = np.array([b3_anywhere(x, y, -0.3, 0.7, 0.1 - size_y / 2, 0.1 + size_y / 2, 1.2) for x, y, _ in points])
    np.testing.assert_allclose(colours, RHO * radiance * factors[:, None], rtol=RTOL)


def test_an_area_light_of_a_spread(floor):
    """Spread 90 degrees: Cycles' soft box profile (``AreaLight.spread_profile``) over the light,
    integrated over 200 x 200 cells; a Cycles render of this set-up read 0.997 / 1.000 / 1.004 of
    it over rings 0-0.4, 0.4-0.8, 0.8-1.2 m out (docs/notes/experiments.md, "An area light's
    Spread"). The bake samples the profile: 2 % (the core's test of it)."""
    lamp = light_object("Box", "AREA", (0.0, 0.0, 1.0), 30.0, shape="SQUARE", size=1.0, spread=math.radians(90))
    points, colours = baked(floor)
    cells = (np.arange(200) + 0.5) / 200 - 0.5
    x, y = (grid.ravel() for grid in np.meshgrid(cells, cells))
    half = math.radians(45)
    expected = []
    for px, py, _ in points:
        distance2 = (x - px) ** 2 + (y - py) ** 2 + 1.0
        cosine = 1.0 / np.sqrt(distance2)
        profile = np.maximum(math.tan(half) - np.sqrt(1 - cosine**2) / cosine, 0) / (math.tan(half) - half)
        expected.append(RHO * 30.0 / math.pi * (profile * cosine**2 / (math.pi * distance2)).sum() / 200**2)
    expected = np.array(expected)
    lit = expected[:, 0] > 0.05 * expected.max()
    np.testing.assert_allclose(colours[lit], expected[lit], rtol=0.02)
    assert lamp.data.spread < math.pi


@pytest.mark.skipif("normalize" not in bpy.types.AreaLight.bl_rna.properties, reason="this Blender always normalizes")
def test_an_area_light_not_normalized_gives_its_power_per_square_unit(floor):
    """Normalize off (5.0 has it, 4.2 not): Cycles takes the power as each square metre's
    (radiance P / pi); a Cycles render of a 2 m light of 100 W 1 m over this floor read 0.999 to
    1.000 of that ring by ring (docs/notes/experiments.md, "An area light's Spread")."""
    light_object("Area", "AREA", (0.2, 0.1, 1.2), 30.0, shape="SQUARE", size=2.0, normalize=False)
    points, colours = baked(floor)
    factors = np.array([b3_anywhere(x, y, -0.8, 1.2, -0.9, 1.1, 1.2) for x, y, _ in points])
    np.testing.assert_allclose(colours, RHO * (30.0 / math.pi) * factors[:, None], rtol=RTOL)


def test_disk_area_light_on_its_axis(floor):
    light_object("Disk", "AREA", (0.0, 0.0, 0.8), 10.0, shape="DISK", size=1.0)
    points, colours = baked(floor)
    centre = np.linalg.norm(points[:, :2], axis=1) < 1e-9
    radiance = 10.0 / (math.pi * math.pi * 0.25)
    np.testing.assert_allclose(colours[centre], np.tile(RHO * radiance * b12(0.5, 0.8), (centre.sum(), 1)), rtol=RTOL)


def test_world_colour_lights_an_open_plane(floor):
    world_colour((0.2, 0.4, 0.8), 1.5)
    _, colours = baked(floor)
    np.testing.assert_allclose(colours, np.tile(RHO * np.array([0.2, 0.4, 0.8]) * 1.5, (len(colours), 1)), rtol=EXACT)


def test_principled_base_colour_is_the_reflectance():
    floor = grid_object("Floor", material=diffuse_material("Floor", RHO, principled=True))
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    _, colours = baked(floor)
    np.testing.assert_allclose(colours, np.tile(RHO * 2.0 / math.pi, (len(colours), 1)), rtol=EXACT)


def test_no_material_is_blenders_default_grey():
    floor = grid_object("Floor")
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    _, colours = baked(floor)
    np.testing.assert_allclose(colours, 0.8 * 2.0 / math.pi, rtol=EXACT)


@pytest.mark.skipif("exposure" not in bpy.types.Light.bl_rna.properties, reason="this Blender has no light exposure")
def test_light_exposure_doubles_per_stop(floor):
    light_object("Sun", "SUN", (0, 0, 5), 2.0, exposure=1.0)
    _, colours = baked(floor)
    np.testing.assert_allclose(colours, np.tile(RHO * 4.0 / math.pi, (len(colours), 1)), rtol=EXACT)


def test_the_sun_angle_softens_its_shadow():
    """Right below a roof's edge, half of a sun of angle 10 degrees is hidden: the floor there
    gets half its light (the roof reflecting nothing, so no light comes back from it)."""
    grey = diffuse_material("Grey", (0.5, 0.5, 0.5))
    floor = grid_object("Floor", 2.0, 2, material=grey)
    roof = grid_object("Roof", 2.0, 1, location=(-1.0, 0.0, 1.0), material=grey, facing_down=True)
    roof.radiosity.reflects = False
    light_object("Sun", "SUN", (0, 0, 5), 2.0, angle=math.radians(10))
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    positions, colours = corner_colours(floor)
    edge = np.isclose(positions[:, 0], 0.0) & np.isclose(positions[:, 1], 0.0)
    np.testing.assert_allclose(colours[edge, :3], 0.5 * 0.5 * 2.0 / np.pi, rtol=0.02)
    outside = positions[:, 0] > 0.5
    np.testing.assert_allclose(colours[outside, :3], 0.5 * 2.0 / np.pi, rtol=1e-3)


def test_a_portal_gives_no_light_of_its_own(floor):
    """An area light marked Portal only guides Cycles' sampling of the world: the floor reads the
    world alone, as without it."""
    world_colour((0.2, 0.4, 0.8), 1.5)
    portal = light_object("Portal", "AREA", (0.0, 0.0, 1.0), 100.0, size=2.0)
    portal.data.cycles.is_portal = True
    _, colours = baked(floor)
    np.testing.assert_allclose(colours, np.tile(RHO * np.array([0.2, 0.4, 0.8]) * 1.5, (len(colours), 1)), rtol=EXACT)


@pytest.mark.parametrize("kind", ["SUN", "AREA", "POINT", "SPOT"])
def test_a_light_with_cast_shadow_off_lights_through_a_roof(kind):
    """Cast Shadow off (``Light.use_shadow``): Cycles traces no shadow ray for the light, so a
    floor under a roof reads what the open floor does (the roof reflecting nothing)."""
    grey = diffuse_material("Grey", (0.5, 0.5, 0.5))
    floor = grid_object("Floor", 2.0, 2, material=grey)
    roof = grid_object("Roof", 4.0, 1, location=(0.0, 0.0, 1.0), material=grey, facing_down=True)
    roof.radiosity.reflects = False
    if kind == "SUN":
        light_object("Light", "SUN", (0, 0, 5), 2.0, use_shadow=False)
        expected = np.full(3, 0.5 * 2.0 / math.pi)
    elif kind == "AREA":
        light_object("Light", "AREA", (0.0, 0.0, 2.0), 30.0, size=1.0, use_shadow=False)
    else:  # a spot wide enough to light the whole floor, of a radius and Soft Falloff
        light_object("Light", kind, (0.0, 0.0, 2.0), 30.0, use_shadow=False, shadow_soft_size=0.3,
                     **({"spot_size": math.radians(120), "spot_blend": 0.0} if kind == "SPOT" else {}))
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    points, colours = corner_colours(floor)
    if kind in ("POINT", "SPOT"):
        offset = np.array([0.0, 0.0, 2.0]) - points
        distance2 = (offset**2).sum(axis=1)
        expected = (0.5 * 30.0 * offset[:, 2] / np.sqrt(distance2) / (4 * math.pi**2 * (distance2 + 0.09)))[:, None]
    if kind == "AREA":
        radiance = 30.0 / math.pi
        expected = (0.5 * radiance
                    * np.array([b3_anywhere(x, y, -0.5, 0.5, -0.5, 0.5, 2.0) for x, y, _ in points]))[:, None]
    np.testing.assert_allclose(colours[:, :3], np.broadcast_to(expected, colours[:, :3].shape), rtol=RTOL)


def test_a_light_or_world_invisible_to_diffuse_rays_lights_no_diffuse_surface(floor):
    """Ray Visibility > Diffuse off: Cycles leaves diffuse surfaces out of that light
    (``light_object_visibility_flags``, the background's SHADER_EXCLUDE_DIFFUSE); the floor reads
    the sun that stays visible alone."""
    world_colour((0.2, 0.4, 0.8), 1.5)
    bpy.context.scene.world.cycles_visibility.diffuse = False
    light_object("Hidden", "POINT", (0.0, 0.0, 1.0), 1000.0).visible_diffuse = False
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    _, colours = baked(floor)
    np.testing.assert_allclose(colours, np.tile(RHO * 2.0 / math.pi, (len(colours), 1)), rtol=EXACT)


def test_what_the_bake_does_not_follow_is_named_in_the_report(addon, floor):
    """Light linking, a light's Max Bounces and a mesh hidden from diffuse rays change a Cycles
    render in ways this bake does not model: each is named in a note, not silently dropped."""
    lamp = light_object("Lamp", "POINT", (0.0, 0.0, 1.0), 100.0)
    lamp.light_linking.receiver_collection = bpy.data.collections.new("Lit")
    lamp.data.cycles.max_bounces = 2
    light_object("Shaded", "SUN", (0.0, 0.0, 5.0), 1.0).light_linking.blocker_collection = \
        bpy.data.collections.new("Blockers")
    floor.visible_diffuse = False
    notes = addon.radiosity_addon.baking.prepare(bpy.context.scene).extraction.notes
    for phrase in ("light 'Lamp': its light linking is not followed", "light 'Lamp': its Max Bounces (2)",
                   "light 'Shaded': its light linking is not followed",
                   "object 'Floor': invisible to diffuse rays in Cycles"):
        assert any(note.startswith(phrase) for note in notes), (phrase, notes)
