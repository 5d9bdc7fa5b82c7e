"""Rays: every visibility query of the project, traced by Embree or, where it cannot load, by a
NumPy ray caster that gives the same answers."""

from .visibility import BACKENDS, RAY_EPSILON, Visibility, default_backend

__all__ = ["Visibility", "default_backend", "BACKENDS", "RAY_EPSILON"]
