"""The Blender layer: properties, panel, operators, scene extraction, write-back and the
``-c radiosity`` command. It gathers settings and calls ``core``; it holds no mathematics.

Until the add-on issue lands, enabling the extension registers nothing: the core is used
through ``python -m core`` (see the README).
"""

classes: tuple = ()


def register() -> None:
    import bpy

    for cls in classes:
        bpy.utils.register_class(cls)


def unregister() -> None:
    import bpy

    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
