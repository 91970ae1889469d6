"""Structured hexahedral tyre meshes built with gmsh (thesis §3.2)."""

from farm.mesh.build import build_mesh
from farm.mesh.cache import mesh_for
from farm.mesh.tyremesh import TyreMesh

__all__ = ["TyreMesh", "build_mesh", "mesh_for"]
