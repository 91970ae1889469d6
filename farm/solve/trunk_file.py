"""A solved trunk as bytes, and back: what a tree sweep keeps in its store (issue 50).

A trunk's states lived only in its worker's memory, so a slide whose worker was lost, a
resumed study and a second client on the same study each solved the trunk again (2 of 6
ccx runs repeated in one case). :mod:`jobs.trees` keeps the trunk in the store
(:mod:`storage.saved`) with this format: one ``.npz`` (NumPy's own, read with
``allow_pickle=False``, so that a store's bytes never run as code) holding every array
and a JSON header of every scalar. Its version is checked when read.
"""

from __future__ import annotations

import dataclasses
import io
import json
import zipfile
from typing import Any, cast

import numpy as np

from farm.errors import FarmError, ResultsError
from farm.solve.states import PathSolution, SolvedState
from farm.solve.tree import Trunk
from farm.specs import LoadPath, RoadMotion

FORMAT = "tyre-farm trunk 1"
_ARRAYS = ("displacement", "strain", "tread_force", "road_reaction", "contact_status",
           "tread_slip", "road_moment")


def _motion(m: RoadMotion | None) -> dict[str, Any] | None:
    return None if m is None else dataclasses.asdict(m)


def state_doc(s: SolvedState, name: str, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """``s``'s scalars as JSON; its arrays put into ``arrays`` under ``name.<field>``."""
    for field in _ARRAYS:
        value = getattr(s, field)
        if value is not None:
            arrays[f"{name}.{field}"] = np.asarray(value)
    return {"deflection": s.deflection, "road_z": s.road_z, "solve_seconds": s.solve_seconds,
            "motion": _motion(s.motion), "rolling_radius": s.rolling_radius}


def dumps(trunk: Trunk) -> bytes:
    """``trunk`` as bytes (:func:`loads` reads them back, equal field by field)."""
    arrays: dict[str, np.ndarray] = {}
    sol = trunk.solution
    header = {
        "format": FORMAT,
        "path": {"deflections": list(trunk.path.deflections), "pressure": trunk.path.pressure,
                 "motion": _motion(trunk.path.motion),
                 "motion_fractions": list(trunk.path.motion_fractions)},
        "reference": state_doc(sol.reference, "reference", arrays),
        "states": [state_doc(s, f"state{k}", arrays) for k, s in enumerate(sol.states)],
        "solve_seconds": sol.solve_seconds, "ccx_runs": sol.ccx_runs,
        "increments": sol.increments, "restarts": len(trunk.restarts),
        "touch_z": trunk.touch_z, "fractions": list(trunk.fractions),
        "failure": trunk.failure, "reroots": list(trunk.reroots),
    }
    for k, block in enumerate(trunk.restarts):
        arrays[f"restart{k}"] = np.frombuffer(block, dtype=np.uint8)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    out = io.BytesIO()
    np.savez(out, allow_pickle=False, **cast(dict[str, Any], arrays))
    return out.getvalue()


def read_state(doc: dict[str, Any], name: str, data: Any) -> SolvedState:
    """The state :func:`state_doc` wrote as ``name`` (``data``: the opened .npz)."""
    found = {f: data[f"{name}.{f}"] for f in _ARRAYS if f"{name}.{f}" in data.files}
    motion = doc["motion"]
    return SolvedState(deflection=doc["deflection"], road_z=doc["road_z"],
                       solve_seconds=doc["solve_seconds"],
                       motion=None if motion is None else RoadMotion(**motion),
                       rolling_radius=doc["rolling_radius"], **found)


def loads(data: bytes) -> Trunk:
    """The trunk :func:`dumps` wrote; :class:`ResultsError` when ``data`` is not one."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            header = json.loads(npz["header"].tobytes())
            if header.get("format") != FORMAT:
                raise ValueError(f"format {header.get('format')!r}, not {FORMAT!r}")
            p = header["path"]
            motion = None if p["motion"] is None else RoadMotion(**p["motion"])
            path = LoadPath(tuple(p["deflections"]), p["pressure"], motion,
                            tuple(p["motion_fractions"]))
            solution = PathSolution(
                read_state(header["reference"], "reference", npz),
                tuple(read_state(s, f"state{k}", npz) for k, s in enumerate(header["states"])),
                header["solve_seconds"], header["ccx_runs"], header["increments"])
            restarts = tuple(npz[f"restart{k}"].tobytes() for k in range(header["restarts"]))
            return Trunk(path, solution, restarts, header["touch_z"],
                         tuple(header["fractions"]), header["failure"],
                         tuple(header["reroots"]))
    except (OSError, EOFError, ValueError, KeyError, TypeError, zipfile.BadZipFile,
            FarmError) as e:  # FarmError: a value the specs refuse (SpecError)
        raise ResultsError(f"a saved trunk does not read back ({type(e).__name__}: {e})") from e
