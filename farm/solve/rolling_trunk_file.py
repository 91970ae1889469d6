"""A solved rolling trunk as bytes, and back: what a rolling tree keeps in its store.

A rolling tree (:mod:`jobs.rolling_trees`) rolls its trunk once and its branches on
from ccx's restart block at the trunk's end. That block lived only in the worker's
memory, so a task re-run after its worker died, or a resumed study, rolled the trunk
again: on the credible tyre (`lean`) a 135 mm trunk costs about 13 min of ccx against
about 3 min a branch (docs/rolling.md). The worker now saves it in the store
(:mod:`storage.saved`, as the static trees' trunks, :mod:`farm.solve.trunk_file`) with
this format: one ``.npz`` read with ``allow_pickle=False`` holding the restart block,
the road's coordinates and the inflated reference's arrays, and a JSON header of every
scalar.

What is not kept is what the task has anyway: the mesh (rebuilt from the model, checked
by its node count), the turned mesh (the mesh turned by ``start``) and the trunk's own
states (a saved trunk is only read once they are stored).
"""

from __future__ import annotations

import dataclasses
import io
import json
import zipfile
from typing import Any, cast

import numpy as np

from farm.ccx.deck import Road
from farm.errors import FarmError, ResultsError
from farm.mesh.tyremesh import TyreMesh
from farm.solve.rolling import turned_mesh
from farm.solve.rolling_tree import RollingTrunk
from farm.solve.trunk_file import read_state, state_doc
from farm.specs import Roll

FORMAT = "tyre-farm rolling trunk 1"


def dumps(trunk: RollingTrunk) -> bytes:
    """``trunk`` as bytes, without its own states (:func:`loads` reads it back)."""
    arrays: dict[str, np.ndarray] = {}
    road = trunk.road
    header = {
        "format": FORMAT, "roll": dataclasses.asdict(trunk.roll),
        "deflection": trunk.deflection, "pressure": trunk.pressure,
        "branch_mm": trunk.branch_mm, "fractions": list(trunk.fractions),
        "start": trunk.start, "centre_z": trunk.centre_z, "seconds": trunk.seconds,
        "increments": trunk.increments, "nodes": trunk.mesh.n_nodes,
        "road": {"first_node": road.first_node, "first_element": road.first_element,
                 "z_top": road.z_top, "lines": list(road.lines)},
        "reference": state_doc(trunk.reference, "reference", arrays),
    }
    arrays["road.xyz"] = np.asarray(road.xyz)
    arrays["restart"] = np.frombuffer(trunk.restart, dtype=np.uint8)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    out = io.BytesIO()
    np.savez(out, allow_pickle=False, **cast(dict[str, Any], arrays))
    return out.getvalue()


def loads(data: bytes, mesh: TyreMesh) -> RollingTrunk:
    """The trunk :func:`dumps` wrote, on ``mesh`` (the model's); :class:`ResultsError`
    when ``data`` is not one, or was solved on another mesh."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            h = json.loads(npz["header"].tobytes())
            if h.get("format") != FORMAT:
                raise ValueError(f"format {h.get('format')!r}, not {FORMAT!r}")
            if h["nodes"] != mesh.n_nodes:
                raise ValueError(f"solved on a mesh of {h['nodes']} nodes, not "
                                 f"{mesh.n_nodes}")
            r = h["road"]
            road = Road(r["first_node"], r["first_element"], r["z_top"], tuple(r["lines"]),
                        npz["road.xyz"])
            reference = read_state(h["reference"], "reference", npz)
            restart = npz["restart"].tobytes()
        return RollingTrunk(Roll(**h["roll"]), h["deflection"], h["pressure"], (), restart,
                            h["branch_mm"], tuple(h["fractions"]), mesh,
                            turned_mesh(mesh, h["start"]), h["start"], reference, road,
                            h["centre_z"], h["seconds"], h["increments"])
    except (OSError, EOFError, ValueError, KeyError, TypeError, zipfile.BadZipFile,
            FarmError) as e:  # FarmError: a value the specs refuse (SpecError)
        raise ResultsError(f"a saved rolling trunk does not read back "
                           f"({type(e).__name__}: {e})") from e
