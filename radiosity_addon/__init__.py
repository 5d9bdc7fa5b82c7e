"""The Blender layer: settings (``properties``), scene reading (``extract``, ``materials``),
the bake as Blender runs it (``baking``), write-back (``write``), operators, panel, the
``-c radiosity`` command (``cli``) and a picture of the result (``preview``). It gathers
settings and calls ``core``; it holds no mathematics."""

from . import cli, operators, panel, properties

modules = (properties, operators, panel, cli)


def register() -> None:
    for module in modules:
        module.register()


def unregister() -> None:
    for module in reversed(modules):
        module.unregister()
