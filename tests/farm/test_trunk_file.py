"""A saved trunk reads back equal, field by field, and nothing else reads as one (issue 50)."""

from __future__ import annotations

import io
import zlib

import numpy as np
import pytest

from farm.errors import ResultsError
from farm.solve import trunk_file
from farm.solve.states import PathSolution, SolvedState
from farm.solve.tree import Trunk
from farm.specs import LoadPath, RoadMotion


def _state(rng, d: float, motion: RoadMotion | None) -> SolvedState:
    combined = motion is not None
    return SolvedState(
        deflection=d, road_z=-300.0 + d, displacement=rng.normal(size=(40, 3)),
        strain=rng.normal(size=(12, 6)), tread_force=rng.normal(size=(8, 3)),
        road_reaction=rng.normal(size=3), solve_seconds=1.5 * d, motion=motion,
        contact_status=rng.integers(0, 3, 8).astype(np.int8) if combined else None,
        tread_slip=rng.normal(size=(8, 3)) if combined else None,
        road_moment=rng.normal(size=3) if combined else None)


def _trunk(motion: RoadMotion | None, failure: str | None = None) -> Trunk:
    rng = np.random.default_rng(7)
    path = LoadPath((10.0, 15.0), 0.2, motion)
    states = tuple(_state(rng, d, motion) for d in path.deflections)
    solution = PathSolution(_state(rng, 0.0, None), states, 12.5, 2, 31)
    restarts = tuple(zlib.compress(rng.bytes(1000 + k)) for k in range(2))
    return Trunk(path, solution, restarts, -287.25, (0.5, 1.0), failure, ("cut back",))


def _equal(a: SolvedState, b: SolvedState) -> None:
    for field in ("deflection", "road_z", "solve_seconds", "motion"):
        assert getattr(a, field) == getattr(b, field), field
    assert np.isnan(a.rolling_radius) and np.isnan(b.rolling_radius)
    for field in trunk_file._ARRAYS:
        x, y = getattr(a, field), getattr(b, field)
        assert (x is None) == (y is None), field
        if x is not None:
            np.testing.assert_array_equal(x, y)
            assert np.asarray(x).dtype == np.asarray(y).dtype


@pytest.mark.parametrize("motion", [None, RoadMotion(friction=0.6, tilt=2.0)])
@pytest.mark.parametrize("failure", [None, "too many cutbacks"])
def test_a_trunk_reads_back_equal(motion, failure):
    trunk = _trunk(motion, failure)
    back = trunk_file.loads(trunk_file.dumps(trunk))
    assert back.path == trunk.path and back.restarts == trunk.restarts
    assert (back.touch_z, back.fractions, back.failure, back.reroots) == (
        trunk.touch_z, trunk.fractions, trunk.failure, trunk.reroots)
    s, t = back.solution, trunk.solution
    assert (s.solve_seconds, s.ccx_runs, s.increments) == (12.5, 2, 31)
    _equal(s.reference, t.reference)
    assert len(s.states) == len(t.states)
    for a, b in zip(s.states, t.states, strict=True):
        _equal(a, b)


def _npz(**arrays) -> bytes:
    out = io.BytesIO()
    np.savez(out, **arrays)
    return out.getvalue()


def _edited(change) -> bytes:
    """A saved trunk whose header ``change`` edited, written back as a valid .npz."""
    import json

    with np.load(io.BytesIO(trunk_file.dumps(_trunk(None)))) as npz:
        arrays = {name: npz[name] for name in npz.files}
    header = json.loads(arrays["header"].tobytes())
    change(header)
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    return _npz(**arrays)


@pytest.mark.parametrize("data", [
    b"", b"not a trunk", trunk_file.dumps(_trunk(None))[:200],
    _npz(header=np.frombuffer(b'{"format": "other"}', dtype=np.uint8)),
    _npz(header=np.array([{"a": 1}], dtype=object)),  # a pickle: never unpickled
    _edited(lambda h: h["path"].update(pressure=-5.0)),  # a pressure no spec takes
], ids=["empty", "text", "cut", "other-format", "pickled", "refused-by-the-spec"])
def test_what_is_not_a_trunk_is_one_error(data):
    with pytest.raises(ResultsError, match="a saved trunk does not read back"):
        trunk_file.loads(data)
