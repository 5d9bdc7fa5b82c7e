"""``bpy.ops.radiosity.bake()`` and ``bpy.ops.radiosity.clear()``.

In the UI the bake is modal: the core works on threads of its own, each timer tick shows its
progress in the status bar, Esc cancels with nothing changed, and the colours are written in
the last step only, so a finished bake is one undo step. In background mode, or when called
from a script without invoking, it runs straight through.
"""

from __future__ import annotations

import bpy

from ..core import BakeCancelled
from .baking import finish, prepare, run_straight

# Seconds of core work per timer tick, and the ticks' interval: the UI stays responsive.
SLICE_BUDGET = 0.1
TICK_INTERVAL = 0.02


class RADIOSITY_OT_bake(bpy.types.Operator):
    """Bake diffuse global illumination (radiosity) into a colour attribute of every mesh"""

    bl_idname = "radiosity.bake"
    bl_label = "Bake Radiosity"
    bl_options = {"REGISTER", "UNDO"}

    _job = None
    _prepared = None
    _timer = None
    running = False  # one bake at a time: a second would write over the first

    @classmethod
    def poll(cls, context):
        if cls.running:
            cls.poll_message_set("A radiosity bake is running (Esc cancels it)")
            return False
        if context.mode != "OBJECT":
            cls.poll_message_set("Switch to Object Mode to bake: colours written in Edit Mode would be lost")
            return False
        return True

    def execute(self, context):
        try:
            prepared = prepare(context.scene, context.view_layer)
            result = run_straight(prepared, echo=bpy.app.background)
            return self._finish(context, prepared, result)
        except BakeCancelled:
            self.report({"WARNING"}, "Bake cancelled: nothing changed")
            return {"CANCELLED"}
        except ValueError as error:
            self.report({"ERROR"}, f"Bake: {error}")
            return {"CANCELLED"}

    def invoke(self, context, event):
        if bpy.app.background or not self.options.is_invoke:
            return self.execute(context)
        try:
            self._prepared = prepare(context.scene, context.view_layer)
        except ValueError as error:
            self.report({"ERROR"}, f"Bake: {error}")
            return {"CANCELLED"}
        self._job = self._prepared.job()
        RADIOSITY_OT_bake.running = True
        manager = context.window_manager
        self._timer = manager.event_timer_add(TICK_INTERVAL, window=context.window)
        manager.modal_handler_add(self)
        manager.progress_begin(0, 100)
        context.workspace.status_text_set("Radiosity: starting (Esc to cancel)")
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._job.cancel()
            self._end(context)
            self.report({"WARNING"}, "Bake cancelled: nothing changed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        finished = self._job.step(SLICE_BUDGET)
        job = self._job
        context.window_manager.progress_update(int(100 * job.fraction))
        context.workspace.status_text_set(f"Radiosity: {100 * job.fraction:.0f}%  {job.message}  (Esc to cancel)")
        if not finished:
            return {"RUNNING_MODAL"}
        self._end(context)
        try:
            result = job.result()
            return self._finish(context, self._prepared, result)
        except BakeCancelled:
            return {"CANCELLED"}
        except ValueError as error:
            self.report({"ERROR"}, f"Bake: {error}")
            return {"CANCELLED"}

    def cancel(self, context):
        """Blender ends the bake (a file opened, the window closed): stop it, nothing written."""
        self._job.cancel()
        self._end(context)

    def _end(self, context) -> None:
        RADIOSITY_OT_bake.running = False
        manager = context.window_manager
        manager.event_timer_remove(self._timer)
        manager.progress_end()
        context.workspace.status_text_set(None)

    def _finish(self, context, prepared, result):
        outcome = finish(prepared, result)
        for note in outcome.notes:
            self.report({"WARNING"}, note)
        self.report({"INFO"}, outcome.summary)
        context.scene.radiosity.last_report = outcome.summary
        _show_colours(context)
        return {"FINISHED"}


class RADIOSITY_OT_clear(bpy.types.Operator):
    """Remove the baked colour attribute from every mesh in the scene"""

    bl_idname = "radiosity.clear"
    bl_label = "Clear Radiosity"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from .write import clear

        name = context.scene.radiosity.attribute_name
        cleared = clear(context.scene.objects, name)
        self.report({"INFO"}, f"Removed '{name}' from {len(cleared)} mesh(es)")
        return {"FINISHED"}


class RADIOSITY_OT_use_in_materials(bpy.types.Operator):
    """Multiply the base colour of the baked objects' materials by the baked colour attribute (for Material
    Preview, and for the glTF exporter, which then writes it as COLOR_0); or undo that"""

    bl_idname = "radiosity.use_in_materials"
    bl_label = "Use Baked Colours in Materials"
    bl_options = {"REGISTER", "UNDO"}

    remove: bpy.props.BoolProperty(name="Remove", default=False,
                                   description="Take the baked colours out of the materials again")

    def execute(self, context):
        from .wiring import baked_materials, unwire, wire

        settings = context.scene.radiosity
        materials = baked_materials(context.scene.objects, settings.attribute_name)
        if self.remove:
            changed = [material.name for material in materials if unwire(material)]
            self.report({"INFO"}, f"Baked colours taken out of {len(changed)} material(s)")
            return {"FINISHED"}
        changed = [material.name for material in materials if wire(material, settings.attribute_name)]
        if settings.output == "RADIOSITY":
            self.report({"WARNING"}, "The bake is Full Radiosity, which already holds the base colour: bake Lighting "
                        "Only to multiply it with the base colour")
        self.report({"INFO"}, f"Baked colours multiply the base colour of {len(changed)} of {len(materials)} "
                    "material(s)")
        return {"FINISHED"}


class RADIOSITY_OT_forget(bpy.types.Operator):
    """Free the memory the last bake keeps so that a bake after colour changes re-solves (the next bake then
    starts afresh)"""

    bl_idname = "radiosity.forget"
    bl_label = "Free Re-bake Memory"

    def execute(self, context):
        from . import sessions

        sessions.forget(context.scene.name)
        context.scene.radiosity.live = False
        return {"FINISHED"}


def _show_colours(context) -> None:
    """Solid-mode 3D views show colour attributes, so the result shows at once."""
    screen = getattr(context, "screen", None)
    for area in screen.areas if screen is not None else ():
        if area.type == "VIEW_3D":
            shading = area.spaces.active.shading
            if shading.type == "SOLID":
                shading.color_type = "VERTEX"


classes = (RADIOSITY_OT_bake, RADIOSITY_OT_clear, RADIOSITY_OT_use_in_materials, RADIOSITY_OT_forget)
register, unregister = bpy.utils.register_classes_factory(classes)
