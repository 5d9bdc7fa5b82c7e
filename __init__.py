"""Radiosity Baker: a Blender extension. register()/unregister() only; the add-on's modules
(and the core behind them) are imported when Blender enables the extension, not before."""


def register() -> None:
    from .radiosity_addon import register as register_addon

    register_addon()


def unregister() -> None:
    from .radiosity_addon import unregister as unregister_addon

    unregister_addon()
