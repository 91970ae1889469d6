"""Finite element virtual experiments of the Trelleborg TM700 280/70R16 slick tyre.

The physics layer of the farm (thesis ch. 3): tyre geometry and gmsh meshes, CalculiX
decks, the one place that runs ``ccx``, result readers and the measurements an in-tyre
camera would take. Nothing here knows about Dask or the store.
"""

__version__ = "0.1.0"
