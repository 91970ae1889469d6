"""The aligning moment of a rolling tyre, read over one tread pitch (issue 30).

A meshed tyre is a polygon of ``n`` elements round: as it rolls, the tread nodes in
contact pass under the wheel centre one element pitch (2 pi r_e / n of travel) at a time,
and the road's normal and lateral forces sit on those few columns of nodes. The moment
about the contact centre, and so the pneumatic trail -Mz/Fy, swings with where the
columns are within the pitch: measured on the thesis wall at 32 elements round (docs/
rolling.md, "The sign of Mz"), -Mz/Fy went from -4 to +33 mm within each 80 mm pitch
of a 2-degree roll, and the 150 mm roll of the first curves had ended at a column
position where it was -4.5 mm. A tyre's trail is the mean over the pitch: this module
averages over states of a roll's last pitch (:func:`farm.solve.rolling.last_pitch`) and
locates the forces on the tread.

Sign: the wheel travels along +x relative to the road (:mod:`farm.solve.rolling`), so
"behind" the contact centre is -x, and a lateral force Fy acting at x = -t gives
Mz = -t Fy: a positive trail t = -Mz / Fy is a force behind the centre.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from farm.mesh.tyremesh import TyreMesh
from farm.solve.rolling import RolledState


def force_centres(state: RolledState, mesh: TyreMesh) -> tuple[float, float]:
    """Where along x (mm, wheel frame) the road's normal and lateral forces on the tread
    act: (x of Fz, x of Fy), each the force-weighted mean x of the deformed tread nodes.
    Their difference is the trail about the centre of pressure."""
    tread = mesh.tread_nodes - 1
    x = mesh.nodes[tread, 0] + np.nan_to_num(state.displacement[tread, 0])
    fy, fz = state.tread_force[:, 1], state.tread_force[:, 2]
    if not fz.sum() > 0 or fy.sum() == 0:
        return float("nan"), float("nan")
    return float(x @ fz / fz.sum()), float(x @ fy / fy.sum())


@dataclass(frozen=True)
class PitchMean:
    """A roll's forces averaged over states spread evenly over one element pitch.

    ``fy`` N, ``mz`` N mm (the means); ``trail`` = -mz / fy, mm, the pneumatic trail about
    the contact centre; ``pressure_trail``: the mean of (x of Fz - x of Fy), mm, the trail
    about the centre of pressure (the normal force's own swing removed); ``mz_range``
    (min, max) of Mz over the pitch, N mm.
    """

    fy: float
    mz: float
    trail: float
    pressure_trail: float
    mz_range: tuple[float, float]


def pitch_mean(states: Sequence[RolledState], mesh: TyreMesh) -> PitchMean:
    """:class:`PitchMean` of ``states`` (those of :func:`farm.solve.rolling.last_pitch`'s
    fractions)."""
    fy = float(np.mean([s.force[1] for s in states]))
    mz = [float(s.moment[2]) for s in states]
    centres = [force_centres(s, mesh) for s in states]
    return PitchMean(fy, float(np.mean(mz)), -float(np.mean(mz)) / fy if fy else float("nan"),
                     float(np.nanmean([z - y for z, y in centres])), (min(mz), max(mz)))
