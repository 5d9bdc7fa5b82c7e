"""Blender materials -> diffuse reflectance, emission (linear RGB) and opacity, with a note for
every approximation. Understood: Principled BSDF (base colour, emission colour x strength, alpha),
Diffuse BSDF, Emission, Transparent BSDF, Mix and Add Shader of those. An Image Texture or a Color
Attribute feeding a base or emission colour straight (not through a mix) is a ``SurfaceMap``, read
per face by ``extract``; elsewhere an image counts as its mean colour. A see-through surface's
reflectance and emission are its whole surface's (``core.Scene.opacity``): a Principled alpha or a
Mix with a Transparent BSDF scales them by the share of light it stops; an Image Texture's Alpha
feeding a Principled alpha through a UV map is its ``opacity_map``, read per face. Anything else
falls back to the material's viewport colour, with a warning."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# Cycles' surface where a mesh has no material: a grey diffuse of 0.8.
DEFAULT_GREY = 0.8
# The core needs reflectance below 1 (a closed scene would have no finite solution otherwise).
MAX_REFLECTANCE = 0.999
# Shares of non-diffuse response worth a note; Principled's default specular (IOR level 0.5)
# is the baseline every material has, so only more than that is mentioned.
SIGNIFICANT_SHARE = 0.01
DEFAULT_SPECULAR_LEVEL = 0.5


class SurfaceMap(NamedTuple):
    """A colour that varies over a surface: ``image`` (a bpy Image) through UV map ``uv_map``, or
    colour attribute ``attribute``; "" names the mesh's active render one. Times ``scale``. With
    ``alpha``, the image's alpha in every channel."""

    image: object | None
    attribute: str | None
    uv_map: str
    scale: float = 1.0
    alpha: bool = False


class Surface(NamedTuple):
    reflectance: np.ndarray  # (3,), the mean where a map varies it
    emission: np.ndarray  # (3,)
    notes: tuple[str, ...]
    reflectance_map: SurfaceMap | None = None
    emission_map: SurfaceMap | None = None
    opacity: float = 1.0  # the share of the light it stops (reflectance and emission are of all of it)
    opacity_map: SurfaceMap | None = None  # per face; reflectance and emission then are the opaque part's


def default_surface() -> Surface:
    return Surface(np.full(3, DEFAULT_GREY), np.zeros(3), ())


def material_surface(material) -> Surface:
    """The diffuse Surface of a bpy Material, or of None (no material)."""
    if material is None:
        return default_surface()
    name = material.name
    tree = material.node_tree if getattr(material, "use_nodes", True) else None
    output = tree.get_output_node("CYCLES") if tree is not None else None
    link = _link_into(output.inputs["Surface"]) if output is not None else None
    if link is None:
        notes = () if tree is None else (f"material '{name}': no surface shader, viewport colour used",)
        return _clamped(Surface(_rgb(material.diffuse_color), np.zeros(3), notes), name)
    notes: list[str] = []
    surface = _shader(link.from_node, name, notes)
    if surface is None:
        notes.append(f"material '{name}': node setup not understood ({link.from_node.bl_idname}), "
                     "viewport colour used")
        surface = Surface(_rgb(material.diffuse_color), np.zeros(3), ())
    return _clamped(surface._replace(notes=tuple(notes)), name)


def _clamped(surface: Surface, name: str) -> Surface:
    cap = MAX_REFLECTANCE * surface.opacity
    if (surface.reflectance <= cap).all():
        return surface
    note = f"material '{name}': reflectance {surface.reflectance.max():.4g} capped at {cap:.4g}"
    if surface.opacity < 1:
        note += f" (a surface of opacity {surface.opacity:.3g} reflects at most that share)"
    return surface._replace(reflectance=np.minimum(surface.reflectance, cap), notes=surface.notes + (note,))


def _shader(node, name: str, notes: list[str]) -> Surface | None:
    """Reflectance and emission of a shader node, None when not understood."""
    node = _through_reroutes(node)
    kind = node.bl_idname
    if kind == "ShaderNodeBsdfPrincipled":
        _note_non_diffuse(node, name, notes)
        emission = _colour(node.inputs["Emission Color" if "Emission Color" in node.inputs else "Emission"],
                           name, notes)
        strength = _value(node.inputs["Emission Strength"], name, notes) if "Emission Strength" in node.inputs else 1.0
        emission_socket = node.inputs["Emission Color" if "Emission Color" in node.inputs else "Emission"]
        surface = Surface(_colour(node.inputs["Base Color"], name, notes), emission * strength, (),
                          surface_map(node.inputs["Base Color"]), surface_map(emission_socket, strength))
        return _with_alpha(surface, node.inputs.get("Alpha"), name, notes)
    if kind == "ShaderNodeBsdfDiffuse":
        return Surface(_colour(node.inputs["Color"], name, notes), np.zeros(3), (), surface_map(node.inputs["Color"]))
    if kind == "ShaderNodeBsdfTransparent":
        if (_rgb(node.inputs["Color"].default_value) < 1 - SIGNIFICANT_SHARE).any() or node.inputs["Color"].is_linked:
            notes.append(f"material '{name}': a Transparent BSDF's colour is taken as white (light passes unfiltered)")
        return Surface(np.zeros(3), np.zeros(3), (), opacity=0.0)
    if kind == "ShaderNodeEmission":
        strength = _value(node.inputs["Strength"], name, notes)
        return Surface(np.zeros(3), _colour(node.inputs["Color"], name, notes) * strength, (),
                       None, surface_map(node.inputs["Color"], strength))
    if kind in ("ShaderNodeMixShader", "ShaderNodeAddShader"):
        shaders = [socket for socket in node.inputs if socket.type == "SHADER"]
        parts = [_shader(link.from_node, name, notes) if (link := _link_into(s)) else _black() for s in shaders]
        if any(part is None for part in parts):
            return None
        if any(part.reflectance_map or part.emission_map for part in parts):
            notes.append(f"material '{name}': a textured colour inside a {node.name} is taken as its mean")
        if any(part.opacity_map for part in parts):
            notes.append(f"material '{name}': a textured alpha inside a {node.name} is taken as its mean")
        if kind == "ShaderNodeAddShader":
            weights = (1.0, 1.0)
            # what one part lets through the other may stop: light passes where neither stops it
            opacity = 1.0 - float(np.prod([1.0 - part.opacity for part in parts]))
        else:
            fac = _value(node.inputs["Fac"], name, notes)
            weights = (1.0 - fac, fac)
            opacity = sum(w * p.opacity for w, p in zip(weights, parts))
        return Surface(sum(w * p.reflectance for w, p in zip(weights, parts)),
                       sum(w * p.emission for w, p in zip(weights, parts)), (), opacity=opacity)
    return None


def _with_alpha(surface: Surface, alpha, name: str, notes: list[str]) -> Surface:
    """A Principled BSDF's ``surface`` with its Alpha (a socket, or None): a mix of a Transparent
    BSDF and the surface by alpha. An Image Texture's Alpha through a UV map becomes the
    ``opacity_map``; other links, their unlinked value."""
    if alpha is None:
        return surface
    link = _link_into(alpha)
    if link is not None:
        found = surface_map(alpha)
        if found is not None and found.image is not None and link.from_socket.name == "Alpha":
            return surface._replace(opacity_map=found._replace(alpha=True))
        notes.append(f"material '{name}': Alpha is driven by nodes; its unlinked value used")
    value = float(alpha.default_value)
    scaled = [None if part is None else part._replace(scale=part.scale * value)
              for part in (surface.reflectance_map, surface.emission_map)]
    return surface._replace(reflectance=surface.reflectance * value, emission=surface.emission * value,
                            reflectance_map=scaled[0], emission_map=scaled[1], opacity=value)


def _black() -> Surface:
    return Surface(np.zeros(3), np.zeros(3), ())


def _note_non_diffuse(node, name: str, notes: list[str]) -> None:
    """Principled inputs that make a surface not purely diffuse, where significant."""
    checks = [("Metallic", "metallic", 0.0), ("Transmission Weight", "transmission", 0.0),
              ("Transmission", "transmission", 0.0), ("Coat Weight", "coat", 0.0),
              ("Specular IOR Level", "specular", DEFAULT_SPECULAR_LEVEL), ("Specular", "specular", 0.5)]
    for socket_name, label, baseline in checks:
        socket = node.inputs.get(socket_name)
        if socket is None:
            continue
        if socket.is_linked or socket.default_value > baseline + SIGNIFICANT_SHARE:
            amount = "textured" if socket.is_linked else f"{socket.default_value:.2f}"
            notes.append(f"material '{name}': {label} {amount} is not diffuse; baked as diffuse base colour")


def surface_map(socket, scale: float = 1.0) -> SurfaceMap | None:
    """The SurfaceMap feeding ``socket`` straight (through reroutes): an Image Texture with an
    image (its UVs from a UV Map node, or the default), or a Color Attribute; else None."""
    link = _link_into(socket)
    if link is None:
        return None
    node = _through_reroutes(link.from_node)
    if node.bl_idname == "ShaderNodeVertexColor":
        return SurfaceMap(None, node.layer_name, "", scale)
    if node.bl_idname != "ShaderNodeTexImage" or node.image is None:
        return None
    vector = _link_into(node.inputs["Vector"])
    source = _through_reroutes(vector.from_node) if vector is not None else None
    if source is not None and source.bl_idname != "ShaderNodeUVMap":
        return None  # generated or object coordinates, a mapping: not a UV footprint
    return SurfaceMap(node.image, None, "" if source is None else source.uv_map, scale)


def _colour(socket, name: str, notes: list[str]) -> np.ndarray:
    """The colour of ``socket``: its value, or the mean of the image or attribute feeding it
    (``extract`` reads a straight SurfaceMap per face instead)."""
    link = _link_into(socket)
    if link is None:
        return _rgb(socket.default_value)
    node = _through_reroutes(link.from_node)
    if node.bl_idname == "ShaderNodeTexImage" and node.image is not None:
        mean = image_mean(node.image)
        if mean is not None:
            if surface_map(socket) is None:
                notes.append(f"material '{name}': textured {socket.name} averaged over image '{node.image.name}' "
                             "(its coordinates are not a UV map)")
            return mean
    if node.bl_idname == "ShaderNodeVertexColor":
        return _rgb(socket.default_value)
    notes.append(f"material '{name}': {socket.name} from a {node.bl_idname} not understood, "
                 "its unlinked value used")
    return _rgb(socket.default_value)


def _value(socket, name: str, notes: list[str]) -> float:
    if _link_into(socket) is not None:
        notes.append(f"material '{name}': {socket.name} is driven by nodes; its unlinked value used")
    return float(socket.default_value)


def image_pixels(image, alpha: bool = False) -> np.ndarray | None:
    """(H, W, 3) linear colour of a Blender image (row 0 at the bottom, as Blender stores it), None
    when it has no pixels (a missing file). Byte images in an sRGB colour space are decoded. With
    ``alpha``, its alpha in every channel (1 where it has none)."""
    channels = image.channels
    width, height = image.size
    count = width * height * channels
    if count == 0 or channels < 3:
        return None
    pixels = np.empty(count, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(height, width, channels)
    if alpha:
        opacity = pixels[..., 3:4] if channels > 3 else np.ones((height, width, 1), np.float32)
        return np.repeat(opacity.astype(np.float64), 3, axis=2)
    rgb = pixels[..., :3].astype(np.float64)
    if not image.is_float and image.colorspace_settings.name == "sRGB":
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    return rgb


def image_mean(image) -> np.ndarray | None:
    """(3,) mean linear colour of a Blender image, None when it has no pixels."""
    pixels = image_pixels(image)
    return None if pixels is None else pixels.reshape(-1, 3).mean(axis=0)


def _link_into(socket):
    return socket.links[0] if socket.is_linked and socket.links else None


def _through_reroutes(node):
    while node.bl_idname == "NodeReroute" and node.inputs[0].is_linked:
        node = node.inputs[0].links[0].from_node
    return node


def _rgb(value) -> np.ndarray:
    return np.array(value[:3], dtype=np.float64)
