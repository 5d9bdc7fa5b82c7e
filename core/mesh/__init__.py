"""Meshing: the scene's triangles merged into panels where flat, cut along contact lines, split
into patches, and grouped into receiver nodes where colours are read; adaptive refinement."""

from .discretize import Discretization, discretised

__all__ = ["Discretization", "discretised"]
