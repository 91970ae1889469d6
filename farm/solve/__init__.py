"""Solving load paths with ccx: rigid-road contact and the thesis' iterative road."""
