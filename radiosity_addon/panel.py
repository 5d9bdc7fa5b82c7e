"""The Radiosity panel: in Render Properties beside Cycles' Bake panel, and in the 3D View's
sidebar (tab "Radiosity"). Presets, the few knobs that matter, Bake and Clear. In Object
Properties, the part each object plays (receives, reflects, emits)."""

from __future__ import annotations

import bpy

from ..core.settings import PRESETS
from . import sessions


def draw_settings(layout, settings) -> None:
    layout.use_property_split = True
    layout.use_property_decorate = False
    layout.prop(settings, "preset")
    if settings.preset == "CUSTOM":
        layout.prop(settings, "patch_size")
        layout.prop(settings, "rays_per_form_factor" if settings.method == "raycast" else "hemicube_resolution")
        layout.prop(settings, "tolerance")
        layout.prop(settings, "refinement_levels")
    else:
        preset = PRESETS[settings.preset]
        column = layout.column(align=True)
        column.active = False
        for part in preset.description.split(": "):  # what it is, then what it is for, on a line each
            column.label(text=part)
    layout.prop(settings, "output")
    layout.prop(settings, "attribute_name")
    layout.prop(settings, "selected_only")
    row = layout.row(align=True)
    row.scale_y = 1.4
    row.operator("radiosity.bake", icon="LIGHT_SUN")
    row.operator("radiosity.clear", text="", icon="TRASH")
    layout.operator("radiosity.use_in_materials", icon="NODE_MATERIAL")
    layout.prop(settings, "light_groups")
    layout.prop(settings, "live", icon="PLAY" if not settings.live else "PAUSE")
    if settings.live and settings.live_status:
        layout.label(text=settings.live_status, icon="INFO")
    session = sessions.kept(settings.id_data.name)
    if session is not None and session.kept_bytes:
        row = layout.row()
        row.label(text=f"Kept for re-bakes: {session.kept_bytes / 2**20:,.0f} MiB", icon="MEMORY")
        row.operator("radiosity.forget", text="", icon="X")
    if settings.last_report:
        box = layout.box()
        box.label(text=settings.last_report, icon="INFO")


def draw_advanced(layout, settings) -> None:
    layout.use_property_split = True
    layout.use_property_decorate = False
    layout.prop(settings, "method")
    layout.prop(settings, "solver")
    column = layout.column()
    column.active = settings.solver == "progressive"
    row = column.row(heading="Limit Shots")
    row.prop(settings, "use_max_shots", text="")
    sub = row.row()
    sub.active = settings.use_max_shots
    sub.prop(settings, "max_shots", text="")
    column.prop(settings, "monte_carlo_rays")
    column.prop(settings, "denoise")
    row = layout.row()
    row.active = settings.solver == "hierarchical"
    row.prop(settings, "link_tolerance")
    layout.prop(settings, "ambient")
    layout.prop(settings, "merge_flat")
    layout.prop(settings, "two_sided")
    layout.prop(settings, "vertex_normals")
    row = layout.row()
    row.active = settings.vertex_normals == "CREASE"
    row.prop(settings, "crease_angle")
    layout.prop(settings, "modified_topology")
    layout.prop(settings, "instances")
    layout.prop(settings, "seed")
    column = layout.column(heading="Colour Attribute")
    column.prop(settings, "separate_direct")
    column.prop(settings, "color_type")
    column.prop(settings, "color_domain")
    column.prop(settings, "exposure")
    row = column.row()
    row.active = settings.color_type == "BYTE_COLOR"
    row.prop(settings, "tone")


class _InRenderProperties:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"


class _InSidebar:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Radiosity"


class _Settings:
    bl_label = "Radiosity Bake"

    def draw(self, context):
        draw_settings(self.layout, context.scene.radiosity)


class _Advanced:
    bl_label = "Advanced"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        draw_advanced(self.layout, context.scene.radiosity)


class RADIOSITY_PT_render(_InRenderProperties, _Settings, bpy.types.Panel):
    bl_options = {"DEFAULT_CLOSED"}


class RADIOSITY_PT_render_advanced(_InRenderProperties, _Advanced, bpy.types.Panel):
    bl_parent_id = "RADIOSITY_PT_render"


class RADIOSITY_PT_sidebar(_InSidebar, _Settings, bpy.types.Panel):
    pass


class RADIOSITY_PT_sidebar_advanced(_InSidebar, _Advanced, bpy.types.Panel):
    bl_parent_id = "RADIOSITY_PT_sidebar"


class RADIOSITY_PT_object(bpy.types.Panel):
    """Object Properties: the part this object plays in the radiosity bake."""

    bl_label = "Radiosity Bake"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        column = layout.column(heading="Object")
        settings = context.object.radiosity
        for name in ("receives", "reflects", "emits"):
            column.prop(settings, name)
        # Blender's own switch (Visibility > Ray Visibility > Shadow), which the bake follows as Cycles does
        column.prop(context.object, "visible_shadow", text="Casts Shadows")


classes = (RADIOSITY_PT_render, RADIOSITY_PT_render_advanced, RADIOSITY_PT_sidebar, RADIOSITY_PT_sidebar_advanced,
           RADIOSITY_PT_object)
register, unregister = bpy.utils.register_classes_factory(classes)
