"""The benchmarks' Cycles vertex bake (bench/in_blender.py: ``unbiased_cycles``, then a COMBINED
bake into a FLOAT_COLOR CORNER attribute) against a closed form.

A floor of reflectance rho under a point light of power P and radius 0 (no world) sees nothing but
the light, so Cycles' every sample of a corner gives rho P cos / (4 pi^2 r^2) (../shared/CYCLES.md).
Cycles evaluates each corner 1e-4 x max(1, |coordinates|) inside its own face: on this floor of
4 m that moves a value by under 1e-3 of itself (the tolerance, 2e-3).

With Blender's default denoiser on, the same bake read 0.36 to 6.4 times the formula: Cycles
denoises the corners as a row of pixels in corner order, so a corner's value is blended with those
of the corners next to it in that order, wherever they lie.
"""

import math

import bpy
import numpy as np

from bench.in_blender import unbiased_cycles
from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object, light_object

RHO = np.array([0.5, 0.4, 0.3])
POWER = 100.0
LIGHT = np.array([0.3, -0.2, 1.0])
RTOL = 2e-3


def test_the_benchmarks_cycles_vertex_bake_gives_a_point_lights_closed_form():
    floor = grid_object("Floor", material=diffuse_material("Floor", RHO))
    light_object("Lamp", "POINT", tuple(LIGHT), POWER, shadow_soft_size=0.0)
    unbiased_cycles(bpy.context.scene, samples=4, seed=0)
    attribute = floor.data.color_attributes.new("cycles", "FLOAT_COLOR", "CORNER")
    floor.data.color_attributes.active_color = attribute
    floor.select_set(True)
    bpy.context.view_layer.objects.active = floor

    assert bpy.ops.object.bake(type="COMBINED", target="VERTEX_COLORS") == {"FINISHED"}

    points, colours = corner_colours(floor, "cycles")
    offset = LIGHT - points
    squared = np.einsum("ij,ij->i", offset, offset)
    cosine = offset[:, 2] / np.sqrt(squared)
    expected = RHO * (POWER * cosine / (4 * math.pi**2 * squared))[:, None]
    np.testing.assert_allclose(colours[:, :3], expected, rtol=RTOL)
