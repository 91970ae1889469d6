"""Meridional section of the tyre: outer contour, wall thickness, inner contour.

The section lies in the (y, r) half-plane, y lateral along the spin axis and r the
distance from it. The outer contour is built from three smooth pieces per side
(thesis §3.2 describes a bead-sidewall-tread-sidewall-bead profile; the TM700 with its
lugs shaven is a slick):

1. a crowned tread arc, centre line to tread edge, dropping ``crown_drop`` mm;
2. a cubic Bezier shoulder from the tread edge (tangent-continuous) to the point of
   maximum section width, where the contour is vertical;
3. a cubic Bezier lower sidewall down to the bead seat on the rim, vertical at both ends.

The inner contour (the cavity wall the camera looks at) is the outer contour offset
inwards by a wall thickness that blends smoothly between the regions' values.
Everything is sampled densely and resampled uniformly in outer arc length per region, so
that a mesh seeded on the samples has elements aligned with the wall normal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from farm.errors import SpecError
from farm.specs import MeshDensity, TyreGeometry

REGIONS = ("bead", "sidewall", "tread", "sidewall", "bead")
"""Regions along the meridian, from the -y bead to the +y bead."""

MAX_WIDTH_HEIGHT = 0.5
"""Height of the maximum section width above the rim, as a fraction of section height."""

BLEND_LENGTH = 30.0
"""Arc length (mm) of sidewall over which its thickness blends into the neighbours'."""


@dataclass(frozen=True, eq=False)
class Section:
    """The sampled section, from the -y bead to the +y bead.

    Attributes
    ----------
    outer, inner : ndarray, shape (n, 2)
        (y, r) of the outer and inner contours; ``inner[k]`` is the offset of ``outer[k]``.
    s : ndarray, shape (n,)
        Arc length along the outer contour.
    region_slices : tuple of slice
        Samples of each region of :data:`REGIONS`; neighbouring slices share their
        boundary sample.
    """

    outer: np.ndarray
    inner: np.ndarray
    s: np.ndarray
    region_slices: tuple[slice, ...]


def _bezier(p0, p1, p2, p3, n: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (
        (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t**2 * p2 + t**3 * p3
    )


def half_outer_contour(g: TyreGeometry, n: int = 4000) -> tuple[np.ndarray, float]:
    """Dense outer contour of the +y half, centre line to bead seat, as (y, r) points.

    Also returns the arc length of the crown (centre line to tread edge).
    """
    a, drop = g.tread_width / 2, g.crown_drop
    rc = (a**2 + drop**2) / (2 * drop)  # crown radius through centre and tread edge
    phi_e = np.arcsin(a / rc)
    phi = np.linspace(0.0, phi_e, n // 4)
    crown = np.column_stack([rc * np.sin(phi), g.outer_radius - rc + rc * np.cos(phi)])

    edge = crown[-1]
    t_edge = np.array([np.cos(phi_e), -np.sin(phi_e)])
    widest = np.array([g.section_width / 2, g.rim_radius + MAX_WIDTH_HEIGHT * g.section_height])
    # Control lengths of a round shoulder: about half the span each way (a quarter-circle
    # Bezier uses 0.55 of its radius), but never reaching beyond the maximum width, so
    # that by the convex-hull property the contour stays within the section width.
    span = np.linalg.norm(widest - edge)
    along = min(0.55 * span, (widest[0] - edge[0]) / t_edge[0])
    shoulder = _bezier(
        edge, edge + along * t_edge, widest + np.array([0.0, 0.55 * span]), widest, n // 4
    )

    seat = np.array([g.rim_width / 2, g.rim_radius])
    drop_side = widest[1] - seat[1]
    lower = _bezier(
        widest,
        widest - np.array([0.0, 0.5 * drop_side]),
        seat + np.array([0.0, 0.5 * drop_side]),
        seat,
        n // 2,
    )
    return np.vstack([crown, shoulder[1:], lower[1:]]), float(rc * phi_e)


def _arc_length(p: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])


def _resample(p: np.ndarray, s: np.ndarray, s_new: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(s_new, s, p[:, 0]), np.interp(s_new, s, p[:, 1])])


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * x)


def wall_thickness(g: TyreGeometry, s: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Wall thickness at outer arc length ``s`` given the 4 inner region boundaries.

    Tread and bead keep their own thickness; the sidewall blends from them to its own
    value over :data:`BLEND_LENGTH` inside the sidewall, so the inner contour stays smooth
    around the shoulder (a blend across the tread edge would dent the cavity wall there).
    """
    outside_tread = np.maximum(bounds[1] - s, 0.0) + np.maximum(s - bounds[2], 0.0)
    outside_bead = np.minimum(np.maximum(s - bounds[0], 0.0), np.maximum(bounds[3] - s, 0.0))
    near_tread = 1.0 - _smoothstep(outside_tread / BLEND_LENGTH)
    near_bead = 1.0 - _smoothstep(outside_bead / BLEND_LENGTH)
    return (
        g.sidewall_thickness
        + (g.tread_thickness - g.sidewall_thickness) * near_tread
        + (g.bead_thickness - g.sidewall_thickness) * near_bead
    )


def build_section(g: TyreGeometry, mesh: MeshDensity, samples_per_element: int = 4) -> Section:
    """Sample the section with ``samples_per_element`` points per element per region."""
    half, crown_len = half_outer_contour(g)
    full = np.vstack([half[::-1] * [-1, 1], half[1:]])  # -y bead ... centre ... +y bead
    s_dense = _arc_length(full)
    total = s_dense[-1]
    mid = total / 2
    bounds = np.array([g.bead_length, mid - crown_len, mid + crown_len, total - g.bead_length])
    if not bounds[0] + 2 * BLEND_LENGTH < bounds[1]:
        raise SpecError(
            f"geometry.bead_length ({g.bead_length} mm) leaves too little sidewall: keep it "
            f"below {bounds[1] - 2 * BLEND_LENGTH:.0f} mm"
        )

    counts = [mesh.bead, mesh.sidewall, mesh.tread, mesh.sidewall, mesh.bead]
    edges = np.concatenate([[0.0], bounds, [total]])
    s_parts, slices, start = [], [], 0
    for k, n_el in enumerate(counts):
        n_s = n_el * samples_per_element
        part = np.linspace(edges[k], edges[k + 1], n_s + 1)
        s_parts.append(part if k == 0 else part[1:])
        slices.append(slice(start, start + n_s + 1))
        start += n_s
    s = np.concatenate(s_parts)

    outer = _resample(full, s_dense, s)
    # tangents from the dense contour: a difference over the coarse samples would tilt
    # the end faces off the rim seat
    tangent = _resample(np.gradient(full, s_dense, axis=0, edge_order=2), s_dense, s)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    inward = np.column_stack([tangent[:, 1], -tangent[:, 0]])  # towards the cavity
    inner = outer + wall_thickness(g, s, bounds)[:, None] * inward
    _check_offset(outer, inner)
    return Section(outer=outer, inner=inner, s=s, region_slices=tuple(slices))


def _check_offset(outer: np.ndarray, inner: np.ndarray) -> None:
    """The inner contour must run the same way as the outer one (no folded offset)."""
    d_out, d_in = np.diff(outer, axis=0), np.diff(inner, axis=0)
    if np.any(np.einsum("ij,ij->i", d_out, d_in) <= 0):
        raise SpecError(
            "the wall is thicker than the contour's radius of curvature (the inner contour "
            "folds over): reduce the wall thickness or widen the shoulder"
        )
