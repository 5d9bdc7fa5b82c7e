"""Baked colours out to game engines: "Use Baked Colours in Materials" makes Blender's glTF
exporter write the bake as COLOR_0, which glTF multiplies with the base colour; read back from the
exported file, COLOR_0 is the baked lighting at every vertex and the base colour is the material's,
so an engine shows base colour x lighting = the radiosity."""

import json
import struct
from pathlib import Path

import bpy
import numpy as np

from tests.addon.blender_scenes import corner_colours, diffuse_material, grid_object, light_object

# glTF accessor component types (glTF 2.0 specification, 3.6.2.2) and element sizes.
COMPONENTS = {5126: np.float32, 5123: np.uint16, 5121: np.uint8}
SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_accessor(document: dict, folder: Path, index: int) -> np.ndarray:
    """(count, size) values of accessor ``index``, normalised integers as floats in [0, 1]."""
    accessor = document["accessors"][index]
    view = document["bufferViews"][accessor["bufferView"]]
    data = (folder / document["buffers"][view["buffer"]]["uri"]).read_bytes()
    dtype, size = np.dtype(COMPONENTS[accessor["componentType"]]), SIZES[accessor["type"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    stride = view.get("byteStride", dtype.itemsize * size)
    rows = [np.frombuffer(data, dtype, size, start + i * stride) for i in range(accessor["count"])]
    values = np.array(rows, dtype=np.float64)
    if accessor.get("normalized"):
        values /= np.iinfo(dtype).max
    return values


def test_exported_gltf_carries_the_bake_as_color_0(tmp_path):
    floor = grid_object("Floor", 2.0, 4, material=diffuse_material("Grey", (0.5, 0.5, 0.5), principled=True))
    light_object("Lamp", "POINT", (0.3, 0.2, 1.0), 30.0)
    settings = bpy.context.scene.radiosity
    settings.output = "LIGHTING"
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    assert bpy.ops.radiosity.use_in_materials() == {"FINISHED"}
    positions, colours = corner_colours(floor)
    baked = {tuple(np.round(p, 5)): c[:3] for p, c in zip(positions, colours)}

    path = tmp_path / "floor.gltf"
    bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLTF_SEPARATE")
    document = json.loads(path.read_text())
    [primitive] = document["meshes"][0]["primitives"]
    assert "COLOR_0" in primitive["attributes"], primitive["attributes"]
    exported = read_accessor(document, tmp_path, primitive["attributes"]["COLOR_0"])[:, :3]
    gltf_positions = read_accessor(document, tmp_path, primitive["attributes"]["POSITION"])
    blender_positions = gltf_positions[:, [0, 2, 1]] * [1, -1, 1]  # glTF is +Y up: (x, z, -y)
    expected = np.array([baked[tuple(np.round(p, 5))] for p in blender_positions])
    assert np.ptp(expected) > 0.05  # the lighting varies over the floor
    assert np.allclose(exported, expected, atol=1.0 / 65535 + 1e-6)
    material = document["materials"][primitive["material"]]
    assert np.allclose(material["pbrMetallicRoughness"]["baseColorFactor"][:3], 0.5)


def test_wiring_again_changes_nothing_and_removing_restores_the_material():
    material = diffuse_material("Grey", (0.5, 0.5, 0.5), principled=True)
    grid_object("Floor", 2.0, 2, material=material)
    light_object("Sun", "SUN", (0, 0, 5), 2.0)
    nodes = material.node_tree.nodes
    before = sorted(node.name for node in nodes)
    assert bpy.ops.radiosity.bake() == {"FINISHED"}
    for _ in range(2):
        assert bpy.ops.radiosity.use_in_materials() == {"FINISHED"}
    base = nodes["Principled BSDF"].inputs["Base Color"]
    assert sorted(node.name for node in nodes) == sorted(before + ["Radiosity Colour", "Radiosity Multiply"])
    assert base.links[0].from_node.name == "Radiosity Multiply"
    assert bpy.ops.radiosity.use_in_materials(remove=True) == {"FINISHED"}
    assert sorted(node.name for node in nodes) == before
    assert not base.is_linked and tuple(base.default_value)[:3] == (0.5, 0.5, 0.5)
