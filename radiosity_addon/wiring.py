"""The baked colour attribute wired into materials: a Color Attribute node multiplies each
material's base colour, as glTF's COLOR_0 does in game engines, so Blender's glTF exporter writes
the bake as COLOR_0 (it exports the colours a material uses) and Material Preview shows them. The
nodes it adds are named, so wiring again only updates them and unwiring restores the material as
it was."""

from __future__ import annotations

ATTRIBUTE_NODE = "Radiosity Colour"
MULTIPLY_NODE = "Radiosity Multiply"
# Shader nodes whose colour input the bake multiplies: the node type and the input's name.
BASE_COLOUR_INPUTS = {"ShaderNodeBsdfPrincipled": "Base Color", "ShaderNodeBsdfDiffuse": "Color"}


def baked_materials(objects, attribute: str) -> list:
    """Materials of the meshes among ``objects`` that hold colour attribute ``attribute``, once each."""
    materials = []
    for obj in objects:
        if obj.type == "MESH" and attribute in obj.data.color_attributes:
            materials += [slot.material for slot in obj.material_slots
                          if slot.material is not None and slot.material not in materials]
    return materials


def wire(material, attribute: str) -> bool:
    """Multiply the base colour of each shader node ``BASE_COLOUR_INPUTS`` names in ``material``
    by colour attribute ``attribute``; False when the material has no such node (nothing changed)."""
    tree = material.node_tree
    if tree is None:
        return False
    existing = tree.nodes.get(ATTRIBUTE_NODE)
    if existing is not None:
        existing.layer_name = attribute
        return True
    targets = [(node, node.inputs[name]) for node in tree.nodes for kind, name in BASE_COLOUR_INPUTS.items()
               if node.bl_idname == kind]
    if not targets:
        return False
    colour = tree.nodes.new("ShaderNodeVertexColor")
    colour.name = colour.label = ATTRIBUTE_NODE
    colour.layer_name = attribute
    for index, (node, socket) in enumerate(targets):
        multiply = tree.nodes.new("ShaderNodeMix")
        multiply.name = multiply.label = MULTIPLY_NODE if index == 0 else f"{MULTIPLY_NODE} {index}"
        multiply.data_type, multiply.blend_type = "RGBA", "MULTIPLY"
        multiply.inputs["Factor"].default_value = 1.0
        multiply.location = node.location.x - 200, node.location.y
        colour.location = multiply.location.x - 200, multiply.location.y - 150
        first, second = _colour_sockets(multiply)
        if socket.is_linked:
            tree.links.new(socket.links[0].from_socket, first)
        else:
            first.default_value = socket.default_value
        tree.links.new(colour.outputs["Color"], second)
        tree.links.new(_colour_output(multiply), socket)
    return True


def unwire(material) -> bool:
    """Remove what ``wire`` added, the base colours linked or set as before; False if it added nothing."""
    tree = material.node_tree
    if tree is None or tree.nodes.get(ATTRIBUTE_NODE) is None:
        return False
    for multiply in [node for node in tree.nodes if node.name.startswith(MULTIPLY_NODE)]:
        first, _ = _colour_sockets(multiply)
        output = _colour_output(multiply)
        for link in list(output.links):
            target = link.to_socket
            if first.is_linked:
                tree.links.new(first.links[0].from_socket, target)
            else:
                tree.links.remove(link)
                target.default_value = first.default_value
        tree.nodes.remove(multiply)
    tree.nodes.remove(tree.nodes[ATTRIBUTE_NODE])
    return True


def _colour_sockets(mix):
    """The Mix node's two colour inputs (A, B): it has one pair per data type, all named alike."""
    sockets = [socket for socket in mix.inputs if socket.type == "RGBA"]
    return sockets[0], sockets[1]


def _colour_output(mix):
    return next(socket for socket in mix.outputs if socket.type == "RGBA")

