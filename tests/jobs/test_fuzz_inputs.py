"""A fuzz corpus of hostile input, run through the real ``farm`` entry point (issue 14).

The corpus is generated deterministically (``random.Random(SEED)``) from a grammar of
mutations of valid study files, inverse studies, reference tables and command lines:
huge, tiny, negative, NaN and infinite numbers, wrong types, missing and unknown keys,
deep nesting, bytes that are not UTF-8, oversized files and grids, odd paths and URLs,
FIFOs, devices and directories given as files, bad scheduler addresses and worker counts.
Every case runs in-process through :func:`tyre_farm_cli.main` in a folder of its own, under a
deadline, against a fake cluster and a fake solver, and is checked for what the CLI
promises (docs/architecture.md "CLI shape", docs/limits.md):

* rejected input: a non-zero exit, exactly one line on stderr starting ``farm: error:``
  (naming the offending key where the case knows it), no traceback, nothing submitted to
  the cluster or the solver, no store created or modified;
* valid input: accepted all the way to the (fake) submission;
* every case ends within :data:`DEADLINE_S` seconds.

Device files that never end (``/dev/urandom``, ``/dev/zero``) run in a subprocess with a
memory cap, so that a reader that regresses to reading them fails the test instead of
exhausting the machine.
"""

from __future__ import annotations

import copy
import hashlib
import importlib
import json
import math
import os
import random
import re
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from tyre_farm_cli import main

SEED = 14
DEADLINE_S = 5.0  # per in-process case
SUBPROCESS_S = 120.0  # all device-file cases, in one subprocess
MEMORY_CAP = 3 << 30  # address space of a device-file case's process

REJECT, SUBMIT, OK = "reject", "submit", "ok"
FAKE_CLUSTER = "fake cluster: submission recorded"
FAKE_SOLVER = "fake solver: load path recorded"
#: `farm run`'s stage lines on stderr (timestamped when stderr is no terminal)
PROGRESS_LINE = re.compile(r"\s*\d{4}-\d\d-\d\dT[\d:]+ run: ")

# ---------------------------------------------------------------------------- the cases


@dataclass(frozen=True)
class Case:
    """One command line and the files it needs; ``expect`` is REJECT, SUBMIT or OK."""

    name: str
    argv: tuple[str, ...]
    expect: str
    files: dict[str, Any] = field(default_factory=dict)  # name -> bytes | ("fifo",) ...
    needle: str | None = None  # a word the error line must contain (the key's name)
    isolated: bool = False  # run in a subprocess (device files)
    xfail: str | None = None  # an owner's defect, not this module's (see the reason)


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # JSON's escapes are TOML basic-string escapes
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)


def toml(data: dict) -> str:
    """Top-level tables as ``[sections]``, deeper tables inline."""
    lines = [f"{k} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines.append(f"\n[{k}]")
            lines += [f"{json.dumps(kk)} = {toml_value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


def with_value(data: dict, path: str, value: Any) -> dict:
    out = copy.deepcopy(data)
    *parents, leaf = path.split(".")
    node = out
    for p in parents:
        node = node.setdefault(p, {})
    node[leaf] = value
    return out


def without(data: dict, path: str) -> dict:
    out = copy.deepcopy(data)
    *parents, leaf = path.split(".")
    node = out
    for p in parents:
        node = node[p]
    del node[leaf]
    return out


COARSE = {"tread": 4, "sidewall": 2, "bead": 1, "circumferential": 8}
REDUCED = {"study": {"name": "fuzz", "store": "store.zarr"},
           "model": {"kind": "reduced", "road": "contact", "mesh": dict(COARSE)},
           "loads": {"deflection_mm": {"start": 5, "stop": 30, "step": 5}},
           "solver": {"max_path_length": 1}}
FULL = {"study": {"name": "fuzz", "store": "store.zarr"},
        "model": {"kind": "full", "mesh": dict(COARSE)},
        "loads": {"pressure_kpa": [200], "deflection_mm": [10, 20]}}
SAMPLED = {**REDUCED, "loads": {"sample": {"method": "lhs", "n": 8, "seed": 0,
                                           "deflection_mm": [5, 30]}}}
INVERSE = {"study": {"name": "fuzz", "store": "inverse.zarr"},
           "model": {"kind": "reduced", "materials": "thesis-calibrated", "mesh": dict(COARSE)},
           "reference": {"deflection_mm": 30},
           "noise": {"displacement_mm": 1.0, "strain": 4e-4},
           "optimizers": {"least-squares": {"max_evaluations": 20}},
           "conditions": [{"name": "ideal", "noise": False, "repeats": 1}]}
STORES = ("store.zarr", "inverse.zarr", "calibration", "analysis-out", "results")


def inverse_toml(data: dict) -> str:
    head = {k: v for k, v in data.items() if k != "conditions"}
    text = toml(head)
    for c in data.get("conditions", []):
        text += "\n[[conditions]]\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in c.items())
    return text


def huge(r: random.Random) -> float:
    return r.choice([1e308, 10 ** r.uniform(10, 300), 1.7976931348623157e308])


def tiny(r: random.Random) -> float:
    return r.choice([1e-308, 5e-324, 10 ** -r.uniform(12, 300)])


def negative(r: random.Random) -> float:
    return -r.choice([1.0, 1e308, 10 ** r.uniform(0, 300)])


NAN, INF = float("nan"), float("inf")
WRONG_TYPES = ("10", True, [1.0], {"x": 1})


@dataclass(frozen=True)
class Key:
    """A numeric key of a study, its valid values and the invalid ones to try."""

    path: str
    base: dict
    valid: Any  # (rng) -> a value the study must accept
    invalid: Any  # (rng) -> list of values it must reject
    needle: str = ""


def _number_bad(r, *, neg=True, big=True, small=False, extra=()):
    out = [NAN, INF, -INF, *r.sample(WRONG_TYPES, 2), *extra]
    if neg:
        out.append(negative(r))
    if big:
        out.append(huge(r))
    if small:
        out.append(tiny(r))
    return out


SWEEP_KEYS = (
    Key("loads.deflection_mm.start", REDUCED, lambda r: round(r.uniform(0.5, 5), 3),
        lambda r: _number_bad(r, small=True, extra=[0, 2 ** 63 - 1]), "deflection"),
    Key("loads.deflection_mm.stop", REDUCED, lambda r: round(r.uniform(5, 170), 3),
        lambda r: _number_bad(r, extra=[0, 200, 2 ** 63 - 1]), "deflection"),
    Key("loads.deflection_mm.step", REDUCED, lambda r: round(r.uniform(0.5, 25), 3),
        lambda r: _number_bad(r, big=False, small=True, extra=[0, 1e-12, 1e-9]), "deflection"),
    Key("loads.deflection_mm", REDUCED, lambda r: sorted(r.sample(range(1, 170), 3)),
        lambda r: [[], [5, NAN], [5, -1], [[5]], "5", [5, 200], {"start": 5}], "deflection"),
    Key("loads.pressure_kpa", FULL, lambda r: round(r.uniform(20, 1000), 1),
        lambda r: _number_bad(r, small=True, extra=[0, 1000.5, 1e5]), "pressure"),
    Key("model.mesh.circumferential", REDUCED, lambda r: 2 * r.randint(2, 40),
        lambda r: _number_bad(r, extra=[0, 3, 10 ** 6, 2 ** 63 - 1, 8.0])),
    Key("model.mesh.tread", REDUCED, lambda r: 2 * r.randint(1, 10),
        lambda r: _number_bad(r, extra=[0, 5, 10 ** 6, 2 ** 62])),
    Key("model.mesh.sidewall", REDUCED, lambda r: r.randint(1, 8),
        lambda r: _number_bad(r, extra=[0, 10 ** 7, 2.5])),
    Key("model.mesh.bead", REDUCED, lambda r: r.randint(1, 4),
        lambda r: _number_bad(r, extra=[0, 10 ** 7])),
    Key("model.materials.tread.youngs_modulus", FULL, lambda r: 10 ** r.uniform(0, 5),
        lambda r: _number_bad(r, small=True, extra=[0, 1e7])),
    Key("model.materials.sidewall.poisson_ratio", FULL, lambda r: r.uniform(-0.9, 0.499),
        lambda r: [NAN, INF, -INF, 0.5, 1.0, -1.0, huge(r), negative(r) - 1, "0.3"]),
    Key("model.geometry.tread_thickness", REDUCED, lambda r: r.uniform(5, 40),
        lambda r: _number_bad(r, small=True, extra=[0, 60])),
    Key("model.geometry.section_width", REDUCED, lambda r: r.uniform(260, 400),
        lambda r: _number_bad(r, extra=[0, 100, 1e5])),
    Key("model.geometry.rim_diameter", REDUCED, lambda r: r.uniform(300, 600),
        lambda r: _number_bad(r, small=True, extra=[0, 1e7])),
    Key("model.contact.clearance", FULL, lambda r: r.uniform(0.1, 2),
        lambda r: _number_bad(r, small=True, extra=[0, 1e4])),
    Key("model.contact.pressure", FULL, lambda r: r.uniform(0.1, 5),
        lambda r: _number_bad(r, small=True, extra=[0, 1e6])),
    Key("model.sector_angle", REDUCED, lambda r: r.uniform(20, 179),
        lambda r: _number_bad(r, extra=[0, 10, 180, 360])),
    Key("solver.timeout_s", REDUCED, lambda r: r.uniform(1, 86400),
        lambda r: _number_bad(r, small=True, extra=[0, 1e-9, 0.5, 1e9])),
    Key("solver.threads", REDUCED, lambda r: r.randint(1, 64),
        lambda r: _number_bad(r, extra=[0, 2 ** 63 - 1, 257, 1.5])),
    Key("solver.initial_increment", REDUCED, lambda r: r.uniform(1e-4, 0.5),
        lambda r: _number_bad(r, small=True, extra=[0, 0.75, 2])),
    Key("solver.min_increment", REDUCED, lambda r: 10 ** r.uniform(-9, -2),
        lambda r: [NAN, INF, 0, -1e-5, 1e-300, 0.3, 2, "1e-5"]),
    Key("solver.max_increments", REDUCED, lambda r: r.randint(1, 10000),
        lambda r: _number_bad(r, extra=[0, 2 ** 63 - 1, 100.0])),
    Key("solver.max_path_length", REDUCED, lambda r: r.randint(0, 100),
        lambda r: [NAN, INF, -1, negative(r), 1.5, "2", True, [1]]),
    Key("loads.sample.n", SAMPLED, lambda r: r.randint(1, 200),
        lambda r: [0, -1, 10 ** 7, 2 ** 63 - 1, 8.0, NAN, "8", True]),
    Key("loads.sample.seed", SAMPLED, lambda r: r.randint(0, 2 ** 31),
        lambda r: [-1, 1.5, NAN, "0", 2 ** 64, True]),
)

INVERSE_KEYS = (
    Key("reference.deflection_mm", INVERSE, lambda r: r.uniform(5, 40),
        lambda r: _number_bad(r, small=True, extra=[0, 200]), "deflection"),
    Key("noise.displacement_mm", INVERSE, lambda r: r.uniform(0.01, 5),
        lambda r: _number_bad(r, extra=[0, 1e9])),
    Key("noise.strain", INVERSE, lambda r: 10 ** r.uniform(-6, -2),
        lambda r: _number_bad(r, extra=[0, 10])),
    Key("optimizers.least-squares.max_evaluations", INVERSE, lambda r: r.randint(2, 200),
        lambda r: [0, 1, -5, 2 ** 63 - 1, 10 ** 9, 20.0, NAN, "20"], "max_evaluations"),
    Key("optimizers.least-squares.fd_step_n", INVERSE, lambda r: r.uniform(0.01, 5),
        lambda r: _number_bad(r, extra=[0]), "fd_step_n"),
    Key("study.seed", INVERSE, lambda r: r.randint(0, 1000),
        lambda r: [-1, 1.5, NAN, "0", 2 ** 64, True]),
)

CONDITION_KEYS = (  # of INVERSE's [[conditions]][0]
    ("repeats", lambda r: r.randint(1, 20), lambda r: [0, -1, 2 ** 63 - 1, 10 ** 6, 1.5, NAN]),
    ("scale", lambda r: r.uniform(0.5, 1.5), lambda r: _number_bad(r, extra=[0, 1e6])),
    ("guess_sigma_n", lambda r: r.uniform(0, 10), lambda r: _number_bad(r, extra=[1e9])),
)


def _study_case(name: str, data: dict, expect: str, needle: str | None = None,
                argv: tuple[str, ...] = ("sweep", "submit", "study.toml"), **kw) -> Case:
    render = inverse_toml if argv[0] == "invert" else toml
    return Case(name, argv, expect, {"study.toml": render(data).encode()}, needle, **kw)


def key_cases(r: random.Random) -> Iterator[Case]:
    for key in SWEEP_KEYS:
        needle = key.needle or key.path.rsplit(".", 1)[-1]
        for k in range(2):
            yield _study_case(f"sweep-{key.path}-valid{k}", with_value(key.base, key.path,
                                                                       key.valid(r)), SUBMIT)
        for k, bad in enumerate(key.invalid(r)):
            yield _study_case(f"sweep-{key.path}-bad{k}-{bad!r:.20}",
                              with_value(key.base, key.path, bad), REJECT, needle)
    inv = ("invert", "study.toml")
    for key in INVERSE_KEYS:
        needle = key.needle or key.path.rsplit(".", 1)[-1]
        yield _study_case(f"invert-{key.path}-valid", with_value(key.base, key.path,
                                                                 key.valid(r)), SUBMIT, argv=inv)
        for k, bad in enumerate(key.invalid(r)):
            yield _study_case(f"invert-{key.path}-bad{k}-{bad!r:.20}",
                              with_value(key.base, key.path, bad), REJECT, needle, argv=inv)
    for leaf, valid, invalid in CONDITION_KEYS:
        data = copy.deepcopy(INVERSE)
        data["conditions"][0][leaf] = valid(r)
        yield _study_case(f"invert-conditions.{leaf}-valid", data, SUBMIT, argv=inv)
        for k, bad in enumerate(invalid(r)):
            data = copy.deepcopy(INVERSE)
            data["conditions"][0][leaf] = bad
            yield _study_case(f"invert-conditions.{leaf}-bad{k}-{bad!r:.20}", data, REJECT,
                              leaf, argv=inv)


def structure_cases(r: random.Random) -> Iterator[Case]:
    for path in ("study", "study.store", "model", "model.kind", "loads",
                 "loads.deflection_mm"):
        yield _study_case(f"missing-{path}", without(REDUCED, path), REJECT,
                          path.rsplit(".", 1)[-1])
    yield _study_case("missing-pressure-full", without(FULL, "loads.pressure_kpa"), REJECT,
                      "pressure_kpa")
    for table in ("study", "model", "loads", "solver", "model.mesh", "model.geometry"):
        unknown = "".join(r.choice("abcdefghij_") for _ in range(8))
        yield _study_case(f"unknown-key-{table}", with_value(REDUCED, f"{table}.{unknown}", 1),
                          REJECT, unknown)
    yield _study_case("unknown-table", {**REDUCED, "extra": {"x": 1}}, REJECT, "extra")
    for table, bad in (("study", 3), ("model", "reduced"), ("loads", [1]), ("solver", True),
                       ("model.mesh", 8), ("model.materials", 3.5)):
        yield _study_case(f"table-as-{type(bad).__name__}-{table}",
                          with_value(REDUCED, table, bad), REJECT, table.rsplit(".", 1)[-1])
    for k, (path, bad) in enumerate((("model.kind", "sideways"), ("model.kind", ""),
                                     ("model.road", "gravel"),
                      ("model.materials", "unobtainium"), ("model.cut_faces", "open"),
                      ("study.group", "../escape"), ("study.group", "a/b"), ("study.group", ""),
                      ("study.group", "x" * 200), ("study.name", 3),
                      ("study.group", "zarr.json"),  # issue 26: failed in create_group
                      ("model.mesh", "fine"),  # an unknown mesh preset (issue 24)
                      ("loads.sample", {"method": "grid", "n": 4, "deflection_mm": [5, 9]}),
                      ("loads.sample", {"method": "lhs", "n": 4, "deflection_mm": [9, 5]}),
                      ("loads.sample", {"method": "lhs", "n": 4, "deflection_mm": [5, NAN]}),
                      ("loads.sample", {"method": "lhs", "n": 4, "deflection_mm": [5, 200]}),
                      ("loads.sample", {"method": "lhs", "n": 4}))):
        yield _study_case(f"bad{k}-{path}-{bad!r:.20}", with_value(REDUCED, path, bad), REJECT,
                          path.rsplit(".", 1)[-1])
    for store in ("", "   ", "a\u0000b.zarr", "x" * 5000, "~no_such_user_fuzz/s.zarr",
                  "bad\nname.zarr", 3, ["s.zarr"], "memory://fuzz", "nosuch://x/y", "s3:/b/x",
                  "s3://", "http://example.com/s.zarr", "://x",
                  # issue 26: accepted before, made into odd directories
                  "res\u202eults.zarr", "C:\\farm\\x.zarr", "D:/farm/x.zarr"):
        yield _study_case(f"store-{store!r:.20}", with_value(REDUCED, "study.store", store),
                          REJECT, "store")
    for store in ("results/new.zarr", "./s.zarr", "deep/er/s.zarr"):
        yield _study_case(f"store-ok-{store}", with_value(REDUCED, "study.store", store), SUBMIT)
    for group in ("g1", "full_table-3.1", "A.b-c"):
        yield _study_case(f"group-ok-{group}", with_value(REDUCED, "study.group", group), SUBMIT)
    yield _study_case("materials-preset", with_value(FULL, "model.materials",
                                                     "thesis-calibrated"), SUBMIT)
    yield _study_case("mesh-preset", with_value(FULL, "model.mesh", "patch"), SUBMIT)
    yield _study_case("sampled-pressures", {**FULL, "loads": {"deflection_mm": [10, 20], "sample": {
        "method": "sobol", "n": 4, "pressure_kpa": [80, 200]}}}, SUBMIT)


def grid_cases(r: random.Random) -> Iterator[Case]:
    """Studies whose experiment count is what is wrong (or, for the last ones, fine)."""
    for k in range(8):
        n_p, n_d = int(10 ** r.uniform(2, 5)), int(10 ** r.uniform(2, 5))
        data = with_value(FULL, "loads.pressure_kpa",
                          {"start": 1, "stop": 1000, "step": 999 / max(n_p - 1, 1)})
        data = with_value(data, "loads.deflection_mm",
                          {"start": 1, "stop": 150, "step": 149 / max(n_d - 1, 1)})
        expect = REJECT if n_p * n_d > 10_000 else SUBMIT
        yield _study_case(f"grid{k}-{n_p}x{n_d}", data, expect,
                          "experiments" if expect == REJECT else None)
    for n in (10 ** 5, 10 ** 6, 10 ** 7):
        yield _study_case(f"sampled-{n}", with_value(SAMPLED, "loads.sample.n", n), REJECT, "n")
    many = with_value(SAMPLED, "loads.sample.n", 5000)
    yield _study_case("sampled-x-pressures", {**many, "model": FULL["model"], "loads": {
        **many["loads"], "pressure_kpa": [80, 120, 200]}}, REJECT, "experiments")
    yield _study_case("grid-ok", with_value(FULL, "loads.pressure_kpa", [80, 120, 160, 200]),
                      SUBMIT)
    yield _study_case("grid-range-1e5", with_value(REDUCED, "loads.deflection_mm", {
        "start": 1, "stop": 150, "step": 149 / 99_999}), REJECT, "deflection")


def file_cases(r: random.Random) -> Iterator[Case]:
    """The study file itself is what is wrong."""
    good = toml(REDUCED).encode()
    sweep = ("sweep", "submit", "study.toml")
    for k in range(4):  # one non-UTF-8 byte in a comment of an otherwise valid study
        at = r.randrange(len(good))
        at = good.rfind(b"\n", 0, at) + 1
        bad = good[:at] + b"# caf" + bytes([r.randrange(0x80, 0x100)]) + b"\n" + good[at:]
        yield Case(f"non-utf8-{k}", sweep, REJECT, {"study.toml": bad}, "UTF-8")
    yield Case("latin-1", sweep, REJECT, {"study.toml": good.decode().replace(
        '"fuzz"', '"caf\u00e9"').encode("latin-1")}, "UTF-8")
    yield Case("utf-16", sweep, REJECT, {"study.toml": good.decode().encode("utf-16")})
    for k in range(3):
        yield Case(f"random-bytes-{k}", sweep, REJECT,
                   {"study.toml": r.randbytes(r.randrange(1, 4096))})
    yield Case("nul-byte", sweep, REJECT, {"study.toml": good.replace(b"fuzz", b"fu\0zz")})
    yield Case("empty", sweep, REJECT, {"study.toml": b""}, "study")
    cut = r.randrange(1, good.index(b"[loads]"))
    yield Case("truncated", sweep, REJECT, {"study.toml": good[:cut]})
    yield Case("json", sweep, REJECT, {"study.toml": json.dumps(REDUCED).encode()})
    for depth in (40, 1000, 100_000):
        arrays = "[" * depth + "]" * depth
        yield Case(f"nested-arrays-{depth}", sweep, REJECT, {"study.toml": good + (
            f"\n[extra]\nx = {arrays}\n").encode()})
        tables = "{a = " * depth + "1" + "}" * depth
        nested = good.replace(b'"name" = "fuzz"', f'"name" = {tables}'.encode())
        assert nested != good
        yield Case(f"nested-tables-{depth}", sweep, REJECT, {"study.toml": nested},
                   "name" if depth < 100 else None)
    dotted = ".".join(["x"] * 5000)
    yield Case("dotted-5000", sweep, REJECT, {"study.toml": good + f"\n{dotted} = 1\n".encode()})
    yield Case("nested-in-key", sweep, REJECT, {"study.toml": toml(with_value(
        REDUCED, "loads.deflection_mm", [[[[[5]]]]])).encode()}, "deflection")
    yield Case("oversized-comment", sweep, REJECT,
               {"study.toml": good + b"#" + b"x" * (2 << 20) + b"\n"}, "MiB")
    values = ", ".join("5" for _ in range(200_000))
    yield Case("oversized-list", sweep, REJECT,
               {"study.toml": good.replace(b"[loads]", b"[ignored]") + (
                   f"\n[loads]\ndeflection_mm = [{values}]\n").encode()})
    yield Case("fifo", sweep, REJECT, {"study.toml": ("fifo",)}, "regular file")
    yield Case("directory", sweep, REJECT, {"study.toml": ("dir",)})
    yield Case("missing-file", sweep, REJECT, {}, "study.toml")
    yield Case("dev-null", ("sweep", "submit", "/dev/null"), REJECT, {}, "regular file")
    yield Case("link-to-fifo", sweep, REJECT, {"study.toml": ("link", "pipe"), "pipe": ("fifo",)})
    yield Case("empty-name", ("sweep", "submit", ""), REJECT)
    for device in ("/dev/urandom", "/dev/zero"):
        yield Case(f"device-{device}", ("sweep", "submit", device), REJECT, {}, "regular file",
                   isolated=True)
        yield Case(f"invert-device-{device}", ("invert", device), REJECT, {}, "regular file",
                   isolated=True)
    yield Case("calibrate-references-urandom", ("calibrate", "--references", "/dev/urandom"),
               REJECT, {}, "regular file", isolated=True)
    yield Case("invert-fifo", ("invert", "study.toml"), REJECT, {"study.toml": ("fifo",)},
               "regular file")
    yield Case("invert-non-utf8", ("invert", "study.toml"), REJECT,
               {"study.toml": inverse_toml(INVERSE).encode() + b"# \xff\n"}, "UTF-8")


SCHEDULERS_BAD = ("not a url", "", " ", "tcp://", "tcp://:8786", "http://host:8786",
                  "tcp://host:0", "tcp://host:99999", "tcp://host:port", "tcp://ho st:1",
                  "tcp://[::1:8786", "a\u0000b:1", "x" * 5000, "file:///tmp/sched",
                  "inproc://", "host:-1", "://host:1", "tcp://host:8786/path?q",
                  "tcp://scheduler", "ucx://10.0.0.1:13337",  # unsupported (issue 26)
                  "tls://scheduler.example:8786")  # TLS without certificates (jobs/tls.py)
SCHEDULERS_OK = ("tcp://127.0.0.1:8786", "127.0.0.1:8786",
                 "tcp://[::1]:8786", "inproc://10.0.0.1/1234/5",
                 "localhost:8786", "ws://host:8786", "tcp://farm_scheduler_1:8786")
WORKERS_BAD = ("-3", "0", "-1", "100000", "x", "1.5", "")


def cluster_option_cases(r: random.Random) -> Iterator[Case]:
    study = {"study.toml": toml(REDUCED).encode()}
    inverse = {"study.toml": inverse_toml(INVERSE).encode()}
    commands = (("sweep", "submit", "study.toml"), ("sweep", "resume", "study.toml"),
                ("invert", "study.toml"), ("calibrate",))
    for k, sched in enumerate(SCHEDULERS_BAD):
        cmd = commands[k % len(commands)]
        yield Case(f"scheduler-bad-{' '.join(cmd[:2])}-{sched!r:.20}",
                   (*cmd, "--scheduler", sched), REJECT,
                   inverse if cmd[0] == "invert" else study, "scheduler")
    for k, sched in enumerate(SCHEDULERS_OK):
        cmd = commands[k % len(commands)]
        yield Case(f"scheduler-ok-{' '.join(cmd[:2])}-{sched}", (*cmd, "--scheduler", sched),
                   SUBMIT, inverse if cmd[0] == "invert" else study)
    for k, workers in enumerate(WORKERS_BAD):
        cmd = commands[k % len(commands)]
        yield Case(f"workers-bad-{' '.join(cmd[:2])}-{workers}", (*cmd, "--workers", workers),
                   REJECT, inverse if cmd[0] == "invert" else study, "workers")
    for workers in ("1", "2"):
        yield Case(f"workers-ok-{workers}", ("sweep", "submit", "study.toml", "--workers",
                                             workers), SUBMIT, study)
    for sched in ("not a url", "tcp://host:99999"):
        yield Case(f"reproduce-scheduler-{sched}", ("reproduce", "--scheduler", sched), REJECT,
                   needle="scheduler")
        yield Case(f"analyse-scheduler-{sched}", ("analyse", "pca", "{store}", "--scheduler",
                                                  sched), REJECT, needle="scheduler")
    yield Case("reproduce-workers", ("reproduce", "--workers", "-3"), REJECT, needle="workers")
    yield Case("reproduce-materials", ("reproduce", "--materials", "nope"), REJECT,
               needle="nope")
    yield Case("invert-repeats-0", ("invert", "study.toml", "--repeats", "0"), REJECT, inverse,
               "repeats")
    yield Case("invert-repeats-neg", ("invert", "study.toml", "--repeats", "-3"), REJECT, inverse,
               "repeats")
    yield Case("invert-repeats-ok", ("invert", "study.toml", "--repeats", "2"), SUBMIT, inverse)
    yield Case("invert-model-full", ("invert", "study.toml"), REJECT, {"study.toml": inverse_toml(
        with_value(INVERSE, "model", {"kind": "full"})).encode()}, "reduced")
    yield Case("invert-no-condition", ("invert", "study.toml"), REJECT, {"study.toml": toml(
        {k: v for k, v in INVERSE.items() if k != "conditions"} | {"conditions": 3}).encode()},
        "conditions")
    yield Case("invert-mask-keep", ("invert", "study.toml"), REJECT, {"study.toml": inverse_toml(
        with_value(INVERSE, "mask", {"eigen_vectors": "pca.csv", "keep": 1.5})).encode()}, "keep")
    yield Case("invert-mask-fifo", ("invert", "study.toml"), REJECT, {
        "pipe.csv": ("fifo",), "study.toml": inverse_toml(with_value(
            INVERSE, "mask", {"eigen_vectors": "pipe.csv"})).encode()}, "regular file")
    yield Case("invert-ok", ("invert", "study.toml"), SUBMIT, inverse)


RUN = ("run", "--model", "reduced", "--set", "mesh.tread=4", "--set", "mesh.sidewall=2",
       "--set", "mesh.bead=1", "--set", "mesh.circumferential=8", "--deflection", "10:20:10")


def run_cases(r: random.Random) -> Iterator[Case]:
    for text in ("10:40:1e-12", "10:40:1e-308", "10:40:5e-324", "nan", "inf", "-inf", "1e308",
                 "10:40", "10:40:5:5", "", ",", "40:10:5", "-5:5:1", "0", "10,nan",
                 "10:inf:1", "nan:40:5", "10:40:0", "10:40:-5", "1e-308", "10:200:10"):
        yield Case(f"run-deflection-{text}", (*RUN, "--deflection", text), REJECT,
                   needle="deflection")
    for text in ("nan", "inf", "-1", "1e308", "1001", "-inf"):
        yield Case(f"run-pressure-{text}", ("run", "--set", "mesh.circumferential=8",
                                            "--pressure", text), REJECT, needle="pressure")
    for text in ("0", "-1", str(2 ** 63 - 1), "257", "1.5"):
        yield Case(f"run-threads-{text}", (*RUN, "--threads", text), REJECT, needle="threads")
    for text in ("0", "1e-9", "0.5", "nan", "inf", "-1", "1e308", "1e9"):
        yield Case(f"run-timeout-{text}", (*RUN, "--timeout", text), REJECT, needle="timeout")
    for item, needle in (("mesh.circumferential=1000000", "circumferential"),
                         ("materials.tread.youngs_modulus=1e308", "youngs_modulus"),
                         ("materials.tread.youngs_modulus=nan", "youngs_modulus"),
                         ("materials.bead.poisson_ratio=0.5", "poisson_ratio"),
                         ("geometry.rim_diameter=1e308", "rim_diameter"),
                         ("sector_angle=nan", "sector_angle"), ("mesh.tread=4.5", "tread"),
                         ("mesh.tread=x", "tread"), ("noequals", "key=value"),
                         ("mesh=3", "mesh"), ("a..b=1", "a"), ("=1", "key"),
                         ("contact.clearance=inf", "clearance"),
                         ("mesh.tread=99999999999999999999", "tread")):
        yield Case(f"run-set-{item}", (*RUN, "--set", item), REJECT, needle=needle)
    for out, files in (("missing/dir/x.npz", {}), ("adir", {"adir": ("dir",)}),
                       ("/dev/null/x.npz", {}), ("afile/x.npz", {"afile": b"x"})):
        yield Case(f"run-out-{out}", (*RUN, "--out", out), REJECT, files, "--out")
    yield Case("run-vtu-file", (*RUN, "--vtu", "afile"), REJECT, {"afile": b"x"}, "--vtu")
    for flag, value in (("--model", "bogus"), ("--road", "sideways"), ("--materials", "nope")):
        yield Case(f"run{flag}-{value}", (*RUN, flag, value), REJECT, needle=value)
    for extra in ((), ("--out", "x.npz"), ("--out", "new.npz", "--vtu", "vtu/new"),
                  ("--threads", "4", "--timeout", "60"), ("--deflection", "5,10,30"),
                  ("--set", "materials.tread.youngs_modulus=12.5")):
        yield Case(f"run-ok-{' '.join(extra)}", (*RUN, *extra), SUBMIT)
    yield Case("run-ok-full", ("run", "--set", "mesh.tread=4", "--set", "mesh.sidewall=2",
                               "--set", "mesh.bead=1", "--set", "mesh.circumferential=8",
                               "--pressure", "200", "--deflection", "10"), SUBMIT)


REFERENCE_HEADER = "model,deflection_mm,pressure_kpa,force_n\n"


def calibrate_cases(r: random.Random) -> Iterator[Case]:
    cal = ("calibrate", "--set", "mesh.tread=4", "--set", "mesh.sidewall=2", "--set",
           "mesh.bead=1", "--set", "mesh.circumferential=8")
    for row in ("reduced,30,0,nan", "reduced,30,0,inf", "reduced,30,0,-1", "reduced,30,0,1e308",
                "reduced,200,0,359", "reduced,1e308,0,359", "reduced,nan,0,359",
                "reduced,30,1e308,359", "reduced,30,abc,359", "sideways,30,0,359",
                "reduced,30,0"):
        yield Case(f"calibrate-row-{row}", (*cal, "--references", "ref.csv"), REJECT,
                   {"ref.csv": (REFERENCE_HEADER + row + "\n").encode()}, "ref.csv")
    for name, data in (("empty", b""), ("header-only", REFERENCE_HEADER.encode()),
                       ("non-utf8", REFERENCE_HEADER.encode() + b"reduced,30,0,3\xff9\n"),
                       ("binary", r.randbytes(512)), ("no-header", b"reduced,30,0,359\n")):
        yield Case(f"calibrate-references-{name}", (*cal, "--references", "ref.csv"), REJECT,
                   {"ref.csv": data}, "ref.csv")
    for name, spec in (("fifo", ("fifo",)), ("dir", ("dir",))):
        yield Case(f"calibrate-references-{name}", (*cal, "--references", "ref.csv"), REJECT,
                   {"ref.csv": spec}, "ref.csv")
    for flag, value, needle in (("--max-evaluations", "-1", "max-evaluations"),
                                ("--max-evaluations", "0", "max-evaluations"),
                                ("--max-evaluations", str(2 ** 63 - 1), "max-evaluations"),
                                ("--prior-weight", "nan", "prior-weight"),
                                ("--prior-weight", "inf", "prior-weight"),
                                ("--prior-weight", "-1", "prior-weight"),
                                ("--parameters", "nope", "nope"),
                                ("--parameters", ",", "parameter"),
                                ("--parameters", "modulus,modulus", "parameter"),
                                ("--model", "sideways", "sideways"),
                                ("--set", "materials.tread.youngs_modulus=-1", "youngs_modulus")):
        yield Case(f"calibrate{flag}-{value:.20}", (*cal, flag, value), REJECT, needle=needle)
    yield Case("calibrate-out-file", (*cal, "--out", "afile"), REJECT, {"afile": b"x"}, "--out")
    yield Case("calibrate-ok", cal, SUBMIT)
    yield Case("calibrate-ok-references", (*cal, "--references", "ref.csv"), SUBMIT,
               {"ref.csv": (REFERENCE_HEADER + "reduced,30,0,359\nfull,30,200,4476\n").encode()})


def analyse_cases(r: random.Random) -> Iterator[Case]:
    for cmd in ("pcr", "plsr", "noise"):
        for value in ("999", "nan", "-1", "inf", "1e308", "27.5"):
            yield Case(f"analyse-{cmd}-reference-{value}",
                       ("analyse", cmd, "{store}", "--reference-deflection", value), REJECT,
                       needle="reference")
    for value in ("nan,1", "inf", "-1", "1,x"):
        yield Case(f"analyse-noise-levels-{value}", ("analyse", "noise", "{store}",
                                                     "--noise-levels", value), REJECT,
                   needle="noise-levels")
    for store in ("missing.zarr", "", "afile", "adir", "nosuch://x"):
        yield Case(f"analyse-store-{store}", ("analyse", "pca", store), REJECT,
                   {"afile": b"x", "adir": ("dir",)})
    yield Case("analyse-group", ("analyse", "pca", "{store}", "--group", "../x"), REJECT,
               needle="group")
    yield Case("analyse-out-file", ("analyse", "pca", "{store}", "--out", "afile"), REJECT,
               {"afile": b"x"}, "afile")
    yield Case("analyse-ok-reference", ("analyse", "plsr", "{store}", "--reference-deflection",
                                        "30", "--components", "2", "--no-nipals"), OK)
    yield Case("export-missing-store", ("export", "missing.zarr"), REJECT)
    yield Case("status-missing-store", ("sweep", "status", "missing.zarr"), REJECT)


MANIFEST = {"format": "tyre-farm-model", "format_version": 1, "model_sha256": "0" * 64,
            "sensor": {}, "inputs": ["displacement"], "targets": ["Fz"]}


def force_model_cases(r: random.Random) -> Iterator[Case]:
    """`farm fit`, `farm predict`, `farm mismatch` (issue 50): numbers, paths, model files."""
    fit = ("fit", "{store}", "--out", "m")
    for option, bad in (("--draws", ["0", "-1", "1.5", "nan", "1001", str(2 ** 63)]),
                        ("--folds", ["0", "1", "-3", "x"]),
                        ("--alpha", ["0", "1", "-0.1", "nan", "inf", "2"]),
                        ("--test-fraction", ["0", "1", "-1", "nan", "5"])):
        for value in bad:
            yield Case(f"fit{option}-{value}", (*fit, option, value), REJECT,
                       needle=option.lstrip("-").split("-")[0])
    for name, out, files in (
            ("empty", "", {}), ("dot", ".", {}), ("file", "afile", {"afile": b"x"}),
            ("link", "alink", {"target": ("dir",), "alink": ("link", "target")}),
            ("dangling", "dangling", {"dangling": ("link", "nowhere")}),
            ("long", "x" * r.randint(256, 400), {}),
            ("other-files", "adir", {"adir": ("dir",), "adir/notes.txt": b"mine"}),
            ("device", "/dev/null", {})):
        yield Case(f"fit-out-{name}", ("fit", "{store}", "--out", out), REJECT, files, "out")
    yield Case("mismatch-draws-0", ("mismatch", "m", "{store}", "--draws", "0"), REJECT,
               needle="draws")
    clouds = ("r.csv", "c.csv")
    model_files = {
        "no-folder": {},
        "empty-folder": {"m": ("dir",)},
        "junk-manifest": {"m": ("dir",), "m/manifest.json": b"\xff\xfe{"},
        "list-manifest": {"m": ("dir",), "m/manifest.json": b"[1, 2, 3]"},
        "no-model": {"m": ("dir",), "m/manifest.json": json.dumps(MANIFEST).encode()},
        "bad-checksum": {"m": ("dir",), "m/manifest.json": json.dumps(MANIFEST).encode(),
                         "m/model.skops": bytes(r.randrange(256) for _ in range(64))},
        "model-a-folder": {"m": ("dir",), "m/manifest.json": json.dumps(MANIFEST).encode(),
                           "m/model.skops": ("dir",)},
        "a-file": {"m": b"not a model"},
    }
    for name, files in model_files.items():
        for cmd, argv in (("predict", ("predict", "m", *clouds)),
                          ("mismatch", ("mismatch", "m", "{store}"))):
            yield Case(f"{cmd}-model-{name}", argv, REJECT, files, "model")


def corpus(seed: int = SEED) -> list[Case]:
    r = random.Random(seed)
    cases = []
    for make in (key_cases, structure_cases, grid_cases, file_cases, cluster_option_cases,
                 run_cases, calibrate_cases, analyse_cases, force_model_cases):
        cases += list(make(r))
    return cases


CASES = corpus()


def test_the_corpus_is_big_deterministic_and_named_uniquely():
    assert len(CASES) >= 300
    assert [c.name for c in corpus()] == [c.name for c in CASES]
    assert [c.files for c in corpus()] == [c.files for c in CASES]
    assert len({c.name for c in CASES}) == len(CASES)
    assert sum(c.expect == REJECT for c in CASES) > 3 * sum(c.expect != REJECT for c in CASES) > 0


# ------------------------------------------------------------------------- the harness


class Deadline(BaseException):
    """The case ran past its deadline (raised from SIGALRM; a BaseException, so that no
    ``except Exception`` on the way turns it into an ordinary error)."""


@contextmanager
def deadline(seconds: float) -> Iterator[None]:
    """Raise :class:`Deadline` in the main thread after ``seconds`` (a blocking open or
    read is interrupted too); the previous handler and timer (pytest-timeout's) are
    restored afterwards."""
    def expire(signum, frame):
        raise Deadline(f"no answer after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    before, _ = signal.setitimer(signal.ITIMER_REAL, seconds)
    start = time.monotonic()
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        if before:
            signal.setitimer(signal.ITIMER_REAL, max(before - (time.monotonic() - start), 0.01))


def make_files(folder: Path, files: dict[str, Any]) -> None:
    for name, spec in files.items():
        path = folder / name
        if isinstance(spec, bytes):
            path.write_bytes(spec)
        elif spec[0] == "fifo":
            os.mkfifo(path)
        elif spec[0] == "dir":
            path.mkdir()
        elif spec[0] == "link":
            path.symlink_to(folder / spec[1])


def fingerprint(folder: Path) -> str:
    """Names, sizes and modification times of everything under ``folder``."""
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        h.update(f"{p.relative_to(folder)} {st.st_size} {st.st_mtime_ns}\n".encode())
    return h.hexdigest()


@dataclass
class Recorder:
    """What reached the cluster or the solver."""

    submissions: list = field(default_factory=list)


@pytest.fixture(scope="module")
def analysis_store(tmp_path_factory) -> Path:
    from tests.synthetic import make_store

    path = tmp_path_factory.mktemp("fuzz-store") / "synthetic.zarr"
    make_store(path, n_experiments=7, rows=4, cols=8, tread_rows=3, tread_cols=6)
    for study in ("crosscov", "pcr", "plsr", "noise"):  # imports are not a case's time
        importlib.import_module(f"analysis.studies.{study}")
    return path


@pytest.fixture(scope="module")
def fake_ccx(tmp_path_factory) -> tuple[Path, Path]:
    """A solver that logs its calls and fails: no case may reach it."""
    folder = tmp_path_factory.mktemp("fake-ccx")
    log, exe = folder / "calls.log", folder / "ccx"
    exe.write_text(f'#!/bin/sh\necho "$@" >> {log}\nexit 1\n')
    exe.chmod(0o755)
    return exe, log


@pytest.fixture(scope="module")
def command():
    """The click command of ``farm``, built once: typer rebuilds it on every call (0.1 s
    of introspection, most of a rejected case's time); the command is the same."""
    import typer.main

    import tyre_farm_cli as cli

    return typer.main.get_command(cli.app)


@pytest.fixture
def recorder(monkeypatch, fake_ccx, command) -> Recorder:
    """Fake cluster and fake load-path solver: they record a submission and refuse it."""
    import typer.main

    import jobs.cluster
    import tyre_farm_cli as cli
    import tyre_farm_cli.run
    from farm.errors import FarmError
    from jobs.errors import ClusterError

    rec = Recorder()
    build = typer.main.get_command
    monkeypatch.setattr(typer.main, "get_command",
                        lambda app: command if app is cli.app else build(app))

    def connect(scheduler=None, workers=None, *args, **kwargs):
        rec.submissions.append(("cluster", scheduler, workers))
        raise ClusterError(FAKE_CLUSTER)

    def run_load_path(spec, path, settings, *args, **kwargs):
        rec.submissions.append(("solver", spec, path, settings))
        raise FarmError(FAKE_SOLVER)

    monkeypatch.setattr(jobs.cluster, "connect", connect)
    monkeypatch.setattr(cli.run, "run_load_path", run_load_path)
    monkeypatch.setenv("FARM_CCX", str(fake_ccx[0]))
    monkeypatch.setenv("HOME", str(fake_ccx[0].parent))  # ~ and caches stay in tmp
    return rec


ISOLATED_RUNNER = """
import contextlib, io, json, sys
from tyre_farm_cli import main
results = {}
for name, argv in json.loads(sys.stdin.read()):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            main(argv)
            code = 0
        except SystemExit as e:
            code = e.code
        except BaseException as e:  # a MemoryError under the cap: a reader read for ever
            code = f"raised {type(e).__name__}"
            err.write(f"Traceback: {type(e).__name__}: {e}")
    results[name] = (code, err.getvalue())
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def isolated(tmp_path_factory, fake_ccx) -> dict[str, tuple[object, str]]:
    """Exit code and stderr of every isolated case, run in ONE subprocess (one interpreter
    start) whose address space is capped: a reader that does not refuse a device file
    ends in a MemoryError there, not in this machine's memory."""
    cases = [(c.name, list(c.argv)) for c in CASES if c.isolated]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "FARM_CCX": str(fake_ccx[0]),
           "PYTHONPATH": str(Path(__file__).resolve().parents[2])}

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))

    try:
        proc = subprocess.run([sys.executable, "-c", ISOLATED_RUNNER], input=json.dumps(cases),
                              capture_output=True, text=True, timeout=SUBPROCESS_S, env=env,
                              preexec_fn=cap, cwd=tmp_path_factory.mktemp("isolated"))
    except subprocess.TimeoutExpired:
        return {name: ("timeout", "") for name, _ in cases}
    try:
        return {k: tuple(v) for k, v in json.loads(proc.stdout.splitlines()[-1]).items()}
    except (IndexError, ValueError):
        return {name: (proc.returncode, proc.stderr[-2000:]) for name, _ in cases}


def run_in_process(case: Case, argv: list[str], capsys) -> tuple[object, str, str]:
    """Exit code, stdout and stderr of ``farm ARGV`` under a deadline."""
    limit = DEADLINE_S if case.expect != OK else 10 * DEADLINE_S  # OK cases do real work
    try:
        with deadline(limit):
            try:
                main(argv)
                code = 0
            except SystemExit as e:
                code = e.code
    except Deadline:
        pytest.fail(f"{case.name}: hangs (no answer after {limit} s)")
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _params():
    for c in CASES:
        marks = [pytest.mark.xfail(reason=c.xfail, strict=False)] if c.xfail else []
        yield pytest.param(c, id=c.name, marks=marks)


@pytest.mark.parametrize("case", list(_params()))
def test_hostile_input(case: Case, tmp_path, monkeypatch, capsys, recorder, analysis_store,
                       fake_ccx, isolated):
    work = tmp_path / "case"
    work.mkdir()
    make_files(work, case.files)
    monkeypatch.chdir(work)
    argv = [a.replace("{store}", str(analysis_store)) for a in case.argv]
    before_store = fingerprint(analysis_store) if "{store}" in case.argv else None
    calls_before = fake_ccx[1].read_text() if fake_ccx[1].exists() else ""
    if case.isolated:
        code, err = isolated[case.name]
        out = ""
        assert code != "timeout", f"{case.name}: no answer after {SUBPROCESS_S} s"
    else:
        code, out, err = run_in_process(case, argv, capsys)
    assert "Traceback" not in out + err, err
    if case.expect == OK:
        assert code in (0, None), err
        return
    assert code not in (0, None), f"{case.name}: exit 0, expected an error; out: {out[-300:]}"
    lines = err.splitlines()
    if case.expect == SUBMIT:  # `farm run` says what it does before it solves: progress
        lines = [ln for ln in lines if not PROGRESS_LINE.match(ln)]
    assert len(lines) == 1 and lines[0].startswith("farm: error: "), err
    if case.expect == SUBMIT:
        assert FAKE_CLUSTER in lines[0] or FAKE_SOLVER in lines[0], lines[0]
        return
    assert FAKE_CLUSTER not in lines[0] and FAKE_SOLVER not in lines[0], f"submitted: {lines[0]}"
    assert not recorder.submissions
    assert (fake_ccx[1].read_text() if fake_ccx[1].exists() else "") == calls_before
    for store in STORES:
        assert not (work / store).exists(), f"{store} created by a rejected input"
    if before_store is not None:
        assert fingerprint(analysis_store) == before_store
    if case.needle:
        assert case.needle.lower() in lines[0].lower(), lines[0]
