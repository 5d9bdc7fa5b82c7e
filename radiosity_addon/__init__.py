"""The Blender layer: settings (``properties``), scene reading (``extract``, ``materials``),
the bake as Blender runs it (``baking``), write-back (``write``), operators, panel, the
``-c radiosity`` command (``cli``), the sessions kept for re-solves (``sessions``) and Live
re-solves while colours change (``live``), and a picture of the result (``preview``). It gathers
settings and calls ``core``; it holds no mathematics."""

from . import cli, live, operators, panel, properties, sessions

modules = (properties, sessions, live, operators, panel, cli)


def register() -> None:
    for module in modules:
        module.register()


def unregister() -> None:
    for module in reversed(modules):
        module.unregister()
