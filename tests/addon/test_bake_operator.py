"""The bake as users meet it: the attribute written (and nothing else), all meshes or none,
cancel changes nothing, undo restores, a second bake gives the same colours, a saved file keeps
them, and what the report says about approximations."""

import re

import bpy
import numpy as np
import pytest

from tests.addon.blender_scenes import (
    bake_in_background, corner_colours, diffuse_material, emission_material, grid_object, light_object,
)

EXACT = 1e-6  # colour attributes store float32: 6e-8 relative, plus the sums in float64


@pytest.fixture
def room():
    """A floor lit by a sun and a glowing panel above it; the floor carries a colour attribute of
    its own ("Col") that a bake must not touch."""
    floor = grid_object("Floor", material=diffuse_material("Floor", (0.6, 0.5, 0.4)))
    col = floor.data.color_attributes.new("Col", "BYTE_COLOR", "POINT")
    col.data.foreach_set("color", np.full(len(floor.data.vertices) * 4, 0.25, dtype=np.float32))
    grid_object("Panel", 1.0, 2, location=(0, 0, 1.0), material=emission_material("Glow", (1, 0.9, 0.8), 5.0),
                facing_down=True)
    light_object("Sun", "SUN", (0, 0, 5), 2.0, rotation=(0.3, 0, 0))
    return floor


def attribute_names(obj) -> list[str]:
    return sorted(attribute.name for attribute in obj.data.attributes)


def test_bake_writes_one_active_float_corner_attribute_per_mesh(room):
    before = attribute_names(room)
    assert bake_in_background() == {"FINISHED"}
    assert attribute_names(room) == sorted(before + ["Radiosity"])
    layer = room.data.color_attributes["Radiosity"]
    assert (layer.data_type, layer.domain) == ("FLOAT_COLOR", "CORNER")
    assert room.data.color_attributes.active_color.name == "Radiosity"
    col = np.empty(len(room.data.vertices) * 4, dtype=np.float32)
    room.data.color_attributes["Col"].data.foreach_get("color", col)
    np.testing.assert_allclose(col, 0.25, atol=1 / 255)  # untouched
    assert "Radiosity" in bpy.data.objects["Panel"].data.color_attributes
    report = bpy.context.scene.radiosity.last_report
    assert "Baked radiosity" in report
    estimated = re.search(r"estimated error ([0-9.e+-]+)% \(solver ([0-9.e+-]+)%, patches ([0-9.e+-]+)%\)", report)
    assert estimated, report  # the bake says how far from converged it may be
    assert float(estimated[1]) >= max(float(estimated[2]), float(estimated[3])) * 0.99


def test_second_bake_replaces_only_its_attribute_with_the_same_colours(room):
    bake_in_background()
    _, first = corner_colours(room)
    names = attribute_names(room)
    bake_in_background()
    _, second = corner_colours(room)
    assert attribute_names(room) == names
    np.testing.assert_array_equal(first, second)


def test_lighting_only_output_is_the_light_before_the_surface_colour(room):
    bake_in_background()
    _, full = corner_colours(room)
    bpy.context.scene.radiosity.output = "LIGHTING"
    bake_in_background()
    _, lighting = corner_colours(room)
    np.testing.assert_allclose(full[:, :3], np.array([0.6, 0.5, 0.4]) * lighting[:, :3], rtol=EXACT)


def test_custom_attribute_name(room):
    bpy.context.scene.radiosity.attribute_name = "GI"
    bake_in_background()
    assert "GI" in room.data.color_attributes and "Radiosity" not in room.data.color_attributes


def test_a_name_taken_by_another_kind_of_attribute_stops_the_bake_before_any_write(room):
    """All meshes or none: the panel could be written, the floor cannot, so neither is."""
    room.data.attributes.new("Radiosity", "FLOAT", "POINT")
    with pytest.raises(RuntimeError, match="not a colour attribute"):
        bpy.ops.radiosity.bake()
    assert "Radiosity" not in bpy.data.objects["Panel"].data.color_attributes
    assert room.data.attributes["Radiosity"].data_type == "FLOAT"


def test_cancel_at_any_stage_changes_nothing(addon, room):
    """The operator's modal steps, driven as its timer would: cancel after k slices, on patches
    fine enough that the bake is still running then."""
    settings = bpy.context.scene.radiosity
    settings.preset, settings.patch_size = "CUSTOM", 0.07
    baking = addon.radiosity_addon.baking
    before = {obj.name: attribute_names(obj) for obj in bpy.data.objects if obj.type == "MESH"}
    for slices in (0, 1, 3, 6):
        prepared = baking.prepare(bpy.context.scene)
        job = prepared.job()
        for _ in range(slices):
            assert not job.step(0.0)
        job.cancel()
        with pytest.raises(addon.core.BakeCancelled):
            job.result()
        assert {obj.name: attribute_names(obj) for obj in bpy.data.objects if obj.type == "MESH"} == before


def test_the_bake_is_one_undo_step():
    """Undo itself needs a window (ed.undo's poll fails in background mode), so what is checked
    here is what makes the bake one undo step: the operator registers undo, and its only change to
    the file happens in one call at the end (see test_cancel_at_any_stage_changes_nothing)."""
    assert "UNDO" in bpy.types.RADIOSITY_OT_bake.bl_options
    assert "UNDO" in bpy.types.RADIOSITY_OT_clear.bl_options


def test_a_saved_and_reopened_file_keeps_the_colours(room, tmp_path):
    bake_in_background()
    _, colours = corner_colours(room)
    path = str(tmp_path / "baked.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_factory_startup=True, use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    _, reopened = corner_colours(bpy.data.objects["Floor"])
    np.testing.assert_array_equal(reopened, colours)
    assert bpy.context.scene.radiosity.attribute_name == "Radiosity"


def test_clear_removes_only_the_baked_attribute(room):
    bake_in_background()
    assert bpy.ops.radiosity.clear() == {"FINISHED"}
    assert "Radiosity" not in room.data.color_attributes and "Col" in room.data.color_attributes


def test_shared_mesh_is_written_once_with_a_note(addon):
    material = diffuse_material("Grey", (0.5, 0.5, 0.5))
    first = grid_object("First", 1.0, 2, material=material)
    second = bpy.data.objects.new("Second", first.data)
    second.location = (3, 0, 0)
    bpy.context.scene.collection.objects.link(second)
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    baking = addon.radiosity_addon.baking
    prepared = baking.prepare(bpy.context.scene)
    outcome = baking.finish(prepared, baking.run_straight(prepared, echo=False))
    assert len(outcome.written) == 1 and "Radiosity" in first.data.color_attributes
    assert any("shared by" in note for note in outcome.notes)


@pytest.mark.parametrize("policy", ["SKIP", "COPY"])
def test_a_modifier_that_changes_topology(addon, policy):
    floor = grid_object("Floor", 2.0, 2, material=diffuse_material("Grey", (0.5, 0.5, 0.5)))
    subdivide = floor.modifiers.new("Subdivide", "SUBSURF")
    subdivide.levels, subdivide.render_levels = 1, 2  # a render subdivides twice: so does the bake
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    bpy.context.scene.radiosity.modified_topology = policy
    baking = addon.radiosity_addon.baking
    prepared = baking.prepare(bpy.context.scene)
    outcome = baking.finish(prepared, baking.run_straight(prepared, echo=False))
    if policy == "SKIP":
        assert outcome.written == [] and "Radiosity" not in floor.data.color_attributes
        assert any("change the topology" in note for note in outcome.notes)
    else:
        copy = bpy.data.objects[outcome.written[0]]
        assert copy is not floor and len(copy.data.loops) == 16 * len(floor.data.loops)
        _, colours = corner_colours(copy)
        np.testing.assert_allclose(colours[:, :3], 0.5 * 2.0 / np.pi, rtol=EXACT)
        assert floor.hide_render


def test_report_names_every_approximation(addon):
    material = diffuse_material("Metal", (0.5, 0.5, 0.5), principled=True)
    material.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0
    textured = diffuse_material("Painted", (0.5, 0.5, 0.5), principled=True)
    image = bpy.data.images.new("paint", 4, 4, float_buffer=True)
    image.pixels.foreach_set(np.tile([0.2, 0.4, 0.6, 1.0], 16).astype(np.float32))
    texture = textured.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    textured.node_tree.links.new(texture.outputs["Color"],
                                 textured.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    odd = bpy.data.materials.new("Odd")
    odd.use_nodes = True
    nodes = odd.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    glossy = nodes.new("ShaderNodeBsdfGlossy")
    odd.node_tree.links.new(glossy.outputs[0], nodes["Material Output"].inputs["Surface"])
    odd.diffuse_color = (0.3, 0.3, 0.3, 1)
    painted = grid_object("Painted", 1.0, 1, location=(0, 0, 0), material=textured)
    grid_object("Metal", 1.0, 1, location=(2, 0, 0), material=material)
    grid_object("Odd", 1.0, 1, location=(4, 0, 0), material=odd)
    curve = bpy.data.objects.new("Curve", bpy.data.curves.new("Curve", "CURVE"))
    bpy.context.scene.collection.objects.link(curve)
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    baking = addon.radiosity_addon.baking
    prepared = baking.prepare(bpy.context.scene)
    outcome = baking.finish(prepared, baking.run_straight(prepared, echo=False))
    notes = "\n".join(outcome.notes)
    assert "'Metal': metallic 1.00 is not diffuse" in notes
    assert "object 'Painted': no UV map, its texture's mean colour used" in notes
    assert "'Odd': node setup not understood (ShaderNodeBsdf" in notes  # Glossy (Anisotropic in 5.0)
    assert "1 curve object(s) skipped" in notes
    _, colours = corner_colours(painted)
    np.testing.assert_allclose(colours[:, :3], np.tile(np.array([0.2, 0.4, 0.6]) * 2.0 / np.pi, (len(colours), 1)),
                               rtol=1e-6)


def test_nothing_to_bake_is_a_clear_error():
    with pytest.raises(RuntimeError, match="no mesh visible in renders"):
        bpy.ops.radiosity.bake()


def test_edit_mode_is_refused_before_anything_is_lost(room):
    bpy.context.view_layer.objects.active = room
    bpy.ops.object.mode_set(mode="EDIT")
    with pytest.raises(RuntimeError, match="Object Mode"):
        bpy.ops.radiosity.bake()
    bpy.ops.object.mode_set(mode="OBJECT")
    assert "Radiosity" not in room.data.color_attributes


def test_a_bad_light_is_named(room):
    bpy.data.objects["Sun"].data.energy = -2.0
    with pytest.raises(RuntimeError, match="light 'Sun': strength must not be negative"):
        bpy.ops.radiosity.bake()


def test_merge_flat_surfaces_reaches_the_core(room):
    """The "Merge Flat Surfaces" setting: on (the default), the 8 x 8 floor (cells of 0.5 m) is
    solved on fewer panels than triangles with 2 m patches and the report says so; off, every
    triangle is a patch of its own."""
    settings = bpy.context.scene.radiosity
    assert settings.merge_flat
    settings.preset, settings.patch_size = "CUSTOM", 2.0
    assert bake_in_background() == {"FINISHED"}
    merged = re.search(r"(\d[\d,]*) triangles merged into (\d[\d,]*) panels", settings.last_report)
    assert merged and int(merged[2].replace(",", "")) < int(merged[1].replace(",", "")), settings.last_report
    settings.merge_flat = False
    assert bake_in_background() == {"FINISHED"}
    assert "merged" not in settings.last_report, settings.last_report


def test_max_shots_reaches_the_core_and_the_report_says_the_bake_stopped(room):
    """"Limit Shots" (Advanced): off, the default, shoots until the tolerance is met; on with
    Max Shots 3 stops the progressive solve after 3 shots, which the report line says, beside the
    solver's share of the estimated error (above the tolerance it did not reach)."""
    settings = bpy.context.scene.radiosity
    assert not settings.use_max_shots
    assert bake_in_background() == {"FINISHED"}
    assert "stopped" not in settings.last_report, settings.last_report
    settings.use_max_shots, settings.max_shots = True, 3
    assert bake_in_background() == {"FINISHED"}
    assert ", stopped after 3 shots, " in settings.last_report, settings.last_report
    solver_share = float(re.search(r"solver ([\d.e+-]+)%", settings.last_report)[1])
    assert solver_share > 100 * settings.tolerance, settings.last_report


def test_monte_carlo_reaches_the_core_after_the_emitters_shoot(room):
    """"Monte Carlo" (Advanced), Auto by default (off where shooting to the tolerance is cheap, as here): with 256
    rays the glowing panel's patches shoot
    (Max Shots 0), the report says the rest went by Monte Carlo, and the colours stay within 2 %
    RMS of the bake shot to its tolerance: the floor sees only the panel and the sun, both exact
    in either bake, so what differs is the little light the floor sends back up (the core's tests,
    tests/core/test_montecarlo.py, measure the convergence on scenes where it matters)."""
    settings = bpy.context.scene.radiosity
    assert settings.monte_carlo_rays == "AUTO"
    assert bake_in_background() == {"FINISHED"}
    assert "Monte Carlo" not in settings.last_report, settings.last_report
    _, shot = corner_colours(room)
    settings.monte_carlo_rays = "256"
    assert bake_in_background() == {"FINISHED"}
    report = settings.last_report
    assert re.search(r", \d+ shots? then Monte Carlo \(256 rays per vertex\), ", report), report
    _, carried = corner_colours(room)
    assert np.sqrt(((carried - shot) ** 2).mean()) <= 0.02 * np.abs(shot).mean()


def lit_sphere(smooth: bool):
    """A faceted UV sphere (grey 0.5) under a sun of strength 2 straight above: nothing else
    reflects, so a corner shows 0.5 x 2 x max(0, n . up) / pi for the normal n it is shaded with."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6, radius=1.0)
    sphere = bpy.context.object
    sphere.data.materials.append(diffuse_material("Grey", (0.5, 0.5, 0.5)))
    sphere.data.shade_smooth() if smooth else sphere.data.shade_flat()
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    return sphere


def widest_spread_at_a_vertex(positions: np.ndarray, colours: np.ndarray) -> float:
    """The largest difference in red between two corners of one vertex."""
    _, vertex = np.unique(np.round(positions, 6), axis=0, return_inverse=True)
    vertex = vertex.reshape(-1)
    low = np.full(vertex.max() + 1, np.inf)
    high = np.full(vertex.max() + 1, -np.inf)
    np.minimum.at(low, vertex, colours[:, 0])
    np.maximum.at(high, vertex, colours[:, 0])
    return float((high - low).max())


def corner_normals_of(obj) -> np.ndarray:
    normals = np.empty(len(obj.data.loops) * 3, dtype=np.float32)
    obj.data.corner_normals.foreach_get("vector", normals)
    return normals.reshape(-1, 3).astype(np.float64)


@pytest.mark.parametrize("smooth", [False, True])
def test_vertex_colours_follow_the_mesh_shading_as_cycles_does(smooth):
    """"Vertex Colours: Follow Shading" (the default): each corner is lit as its shading normal
    says, Shade Flat or Smooth (Cycles shades a corner so). Away from the terminator (n . up >
    0.3, where no shadow ray grazes a facet), within 1e-3 of the exact value; smooth corners of a
    vertex then share one colour, flat ones do not."""
    sphere = lit_sphere(smooth)
    assert bpy.context.scene.radiosity.vertex_normals == "SHADING"
    assert bake_in_background() == {"FINISHED"}
    positions, colours = corner_colours(sphere)
    cosine = corner_normals_of(sphere)[:, 2]
    lit = cosine > 0.3
    np.testing.assert_allclose(colours[lit, 0], 0.5 * 2.0 * cosine[lit] / np.pi, rtol=1e-3)
    assert (widest_spread_at_a_vertex(positions, colours) < 1e-6) == smooth


def test_crease_angle_mode_ignores_the_shading():
    """"Crease Angle" with 60 degrees on the flat-shaded sphere (whose facets meet at 30 degrees):
    the corners of a vertex share one colour though the mesh is shaded flat."""
    sphere = lit_sphere(smooth=False)
    settings = bpy.context.scene.radiosity
    settings.vertex_normals, settings.crease_angle = "CREASE", np.radians(60)
    assert bake_in_background() == {"FINISHED"}
    assert widest_spread_at_a_vertex(*corner_colours(sphere)) < 1e-6


def discretised_as_baked(addon):
    """The bake's discretisation of the current scene, and its settings resolved."""
    core = addon.core
    prepared = addon.radiosity_addon.baking.prepare(bpy.context.scene)
    scene = prepared.extraction.scene
    knobs = core.settings.resolved(core.BakeSettings(**prepared.knobs), scene.extent)
    return core.mesh.discretize.discretised(scene, knobs.patch_size, np.radians(knobs.crease_angle),
                                            knobs.merge_flat)[0]


def test_monte_carlo_auto_carries_a_large_scene_after_the_emitters_shoot(addon):
    """Auto turns Monte Carlo on where a round of shots would cost core.settings.LARGE_SCENE_SHOOTING
    form factors or more, patches x (patches + vertices), times up to MAX_REFINEMENT for patches
    finer than the default: a floor of 40 x 40 cells under a glowing panel, at patches of 0.07 (about
    29,000 patches and 1,700 vertices), bakes with 64 rays, and the report says so; at the automatic
    patch size (a few dozen patches) it shoots to the tolerance."""
    grid_object("Floor", cells=40, material=diffuse_material("Floor", (0.6, 0.5, 0.4)))
    grid_object("Panel", 1.0, 2, location=(0, 0, 1.0), material=emission_material("Glow", (1, 0.9, 0.8), 5.0),
                facing_down=True)
    settings = bpy.context.scene.radiosity
    settings.preset, settings.patch_size = "CUSTOM", 0.07
    mesh = discretised_as_baked(addon)
    line = addon.core.settings.MAX_REFINEMENT * addon.core.settings.LARGE_SCENE_SHOOTING
    assert mesh.patch_count * (mesh.patch_count + mesh.node_count) >= line
    assert bake_in_background() == {"FINISHED"}
    assert "then Monte Carlo (64 rays per vertex)" in settings.last_report, settings.last_report
    settings.patch_size = 0.0
    mesh = discretised_as_baked(addon)
    assert mesh.patch_count * (mesh.patch_count + mesh.node_count) < addon.core.settings.LARGE_SCENE_SHOOTING
    assert bake_in_background() == {"FINISHED"}
    assert "Monte Carlo" not in settings.last_report, settings.last_report


def glowing_principled(name: str, base: float, strength: float):
    """An emissive Principled BSDF whose base colour also reflects, as Blender's emissive
    materials usually do."""
    material = diffuse_material(name, (base, base, base), principled=True)
    shader = material.node_tree.nodes["Principled BSDF"]
    shader.inputs["Emission Color"].default_value = (1.0, 0.9, 0.8, 1.0)
    shader.inputs["Emission Strength"].default_value = strength
    return material


def test_monte_carlo_auto_finishes_when_the_emitters_reflect(addon):
    """The floor of the test above (patches of 0.14) under two emissive Principled panels facing
    each other, each reflecting half the light: every shot of one lights the other again, and
    Auto's Monte Carlo must still take over once each emitting patch has shot its own light (at
    most one shot per emitting patch, counted here on the same discretisation the bake made)."""
    grid_object("Floor", cells=40, material=diffuse_material("Floor", (0.6, 0.5, 0.4)))
    grid_object("Upper", 1.0, 2, location=(0, 0, 1.0), material=glowing_principled("Upper", 0.5, 5.0),
                facing_down=True)
    grid_object("Lower", 1.0, 2, location=(0, 0, 0.6), material=glowing_principled("Lower", 0.5, 2.0))
    settings = bpy.context.scene.radiosity
    settings.preset, settings.patch_size = "CUSTOM", 0.14
    assert bake_in_background() == {"FINISHED"}
    shots = re.search(r", ([\d,]+) shots? then Monte Carlo \(64 rays per vertex\)", settings.last_report)
    assert shots, settings.last_report
    mesh = discretised_as_baked(addon)
    assert int(shots[1].replace(",", "")) <= int(mesh.patch_emission.any(axis=1).sum())
