"""Model-space designs: a study's ``[models]`` table sweeps :class:`farm.specs.ModelSpec`
fields alongside the loads (issue 15, thesis §6.2 "a more extensive sensitivity study").

A design names model fields by their dotted path in the study's ``[model]`` (as
``farm run --set`` does) and how to vary them::

    [models]
    method = "sobol"    # "grid" | "lhs" | "sobol" | "morris"
    n = 8               # lhs: points; sobol: base N -> N (D + 2) models; morris: r -> r (D + 1)
    seed = 0
    [models.parameters]
    "materials.tread.youngs_modulus" = [2.0, 12.0]           # a range [low, high]
    "mesh.circumferential" = { levels = [8, 12, 16] }        # discrete levels

``grid`` takes every combination of each parameter's values (a list, a ``{start, stop,
step}`` range, or ``{levels = [...]}``); ``lhs`` draws ``n`` points of a Latin hypercube
(``scipy.stats.qmc``, as :mod:`jobs.expand` does for loads); ``sobol`` is SALib's
Saltelli/Sobol' design for first and total Sobol' indices (``calc_second_order=False``:
``N (D + 2)`` rows; Saltelli 2002, Saltelli et al. 2010); ``morris`` SALib's ``r``
elementary-effect trajectories of ``r (D + 1)`` rows (Morris 1991, Campolongo et al.
2007), ``num_levels`` grid levels (default 4).

Ranges ``[low, high]`` are for float fields. Integer and text fields (mesh densities,
``road``, ``cut_faces``) take ``{levels = [...]}``: the design's unit coordinate ``u``
picks level ``floor(u k)`` of ``k`` under LHS, ``round(u (k - 1))`` on Morris' grid (so
that every Morris step changes the level it moves), and under Sobol' the level of a
randomly relabelled stratum, see :func:`sobol_level`. Values are rounded to
:data:`jobs.identity.DIGITS` decimals before they reach a model, so that ids do not
hang on the last bit of a float.

Why Sobol' levels are not ``floor(u k)``: Saltelli's estimators need the B matrix to be
an independent redraw of A, so that the swap A -> AB_j changes a parameter in the share
``1 - 1/k`` of the rows that two independent draws of ``k`` equally likely levels
differ in (Saltelli 2002; Saltelli et al. 2010, the Jansen estimator of ST averages
``(f(A) - f(AB_j))^2``, and rows whose swap changes nothing add exactly 0). Two levels
from ``floor(2 u)`` read only the first binary digit of a Sobol' coordinate, and every
Sobol' dimension's first direction number is 1: for some column pairs (j, j + D) of the
2D-dimensional sequence, e.g. the sixth parameter of six, the first digits of A and B
are the same in every row, or opposite in every row, whatever the scrambling seed.
Then the swap never changes the level (indices 0 by construction) or always does (ST
doubled for two levels). Each column of N = 2^m Sobol' points has one point in each of
the N strata ``[s/N, (s+1)/N)``; relabelling the strata by a random permutation seeded
from the design's seed and the parameter's position keeps that (each level still taken
N/k times when k divides N) but breaks the digit pattern shared by A and B. It cannot
rule out an unlucky draw, so :func:`check_swaps` refuses a design whose swaps change a
level parameter implausibly rarely or often for independent draws (another seed fixes it).

:func:`model_design` is deterministic (seeded samplers): the analysis side regenerates
the design from the study file to line the rows up with the store's groups. Rows with
equal models share one group (``"<kind>-<model hash[:10]>"``, as
:attr:`jobs.study.Study.group_name`). Every model is validated when the study is
loaded: an invalid row is one :class:`~jobs.errors.StudyError` naming the parameter,
the row's value and the allowed range, before anything is submitted.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from scipy.stats import qmc

from farm.specs import ModelSpec
from jobs.errors import StudyError
from jobs.identity import DIGITS, model_hash
from jobs.validate import limits, lists, scalars, spec_tables
from jobs.validate.messages import fail, shown

METHODS = ("grid", "lhs", "sobol", "morris")
MODELS_KEYS = {"method", "n", "seed", "num_levels", "parameters", "loads"}
#: How a design's models meet the study's load cases: "shared" (every model runs the same
#: cases: what a sensitivity analysis compares) or "own" (each model draws its own cases
#: from the same sampled design, re-seeded by its row: a population of tyres in which no
#: two share a load case, issue 47, docs/population.md)
LOADS = ("shared", "own")
FIXED_FIELDS = ("kind",)  # one study, one model kind (its inflation and load checks)
MAX_ROWS = 100_000  # rows a design may have before its models are made (memory bound)
#: A sobol design is refused when a level parameter's A -> AB_j swap changes it in a number
#: of base rows that independent draws of A and B would give with a two-sided binomial
#: probability below this (or in fewer than MIN_SWAPPED base rows: an index resting on one
#: difference has no meaningful bootstrap interval). 1 %: N = 8 two-level designs are refused
#: when 0 or 8 of 8 rows change (p = 0.008), kept from 1 to 7.
SWAP_P_VALUE = 0.01
MIN_SWAPPED = 2


@dataclass(frozen=True)
class Parameter:
    """One varied model field: a range ``(low, high)`` or discrete ``levels``.

    ``path`` is the dotted path in :meth:`farm.specs.ModelSpec.to_dict`; for a grid,
    ``levels`` are the values taken.
    """

    path: str
    low: float | None = None
    high: float | None = None
    levels: tuple[Any, ...] | None = None

    @property
    def numeric(self) -> bool:
        return self.levels is None or all(_is_number(x) for x in self.levels)

    @property
    def span(self) -> tuple[float, float]:
        """``(low, high)`` of a range parameter."""
        assert self.low is not None and self.high is not None, f"{self.path} takes levels"
        return self.low, self.high

    @property
    def choices(self) -> tuple[Any, ...]:
        """The levels of a levels parameter (every parameter of a grid is one)."""
        assert self.levels is not None, f"{self.path} is a range"
        return self.levels

    @property
    def bounds(self) -> tuple[float, float]:
        """The range the design's matrix spans: the range, or the levels' extremes
        (their index range for text levels)."""
        if self.levels is None:
            return self.span
        if not self.numeric:
            return (0.0, float(len(self.levels) - 1))
        return (float(min(self.levels)), float(max(self.levels)))

    def allowed(self) -> str:
        """What the parameter may take, for messages."""
        if self.levels is None:
            return f"range [{self.low:g}, {self.high:g}]"
        return f"levels {list(self.levels)}"


@dataclass(frozen=True)
class ModelsSpec:
    """A validated ``[models]`` table (what :class:`jobs.study.Study` holds)."""

    method: str
    n: int  # lhs: points; sobol: base N; morris: trajectories; grid: unused (0)
    seed: int
    parameters: tuple[Parameter, ...]
    num_levels: int = 4  # morris only
    loads: str = "shared"  # LOADS

    @property
    def rows(self) -> int:
        """Rows of the design, counted without sampling."""
        d = len(self.parameters)
        if self.method == "grid":
            return math.prod(len(p.choices) for p in self.parameters)
        return {"lhs": self.n, "sobol": self.n * (d + 2), "morris": self.n * (d + 1)}[
            self.method]


@dataclass(frozen=True, eq=False)
class ModelDesign:
    """A study's design over model fields, with one model and one store group per row.

    Attributes
    ----------
    method : "grid", "lhs", "sobol" or "morris".
    names : tuple of str, shape (D,)
        Dotted ModelSpec paths, in the file's order.
    bounds : tuple of (low, high), shape (D,)
        What each column spans (:attr:`Parameter.bounds`).
    n, seed : the table's ``n`` (0 for a grid) and seed.
    matrix : ndarray, shape (rows, D)
        The value each row gives each parameter (the level's index for text levels),
        rows in SALib's sample order for sobol and morris.
    models : tuple of ModelSpec, shape (rows,)
    groups : tuple of str, shape (rows,)
        ``"<kind>-<model hash[:10]>"`` per row: equal models share a group.
    """

    method: str
    names: tuple[str, ...]
    bounds: tuple[tuple[float, float], ...]
    n: int
    seed: int
    matrix: np.ndarray
    models: tuple[ModelSpec, ...]
    groups: tuple[str, ...]

    def problem(self) -> dict:
        """SALib's problem: ``{"num_vars", "names", "bounds"}``."""
        return {"num_vars": len(self.names), "names": list(self.names),
                "bounds": [list(b) for b in self.bounds]}

    def distinct(self) -> dict[str, ModelSpec]:
        """Group -> model, each group once, in row order."""
        return dict(zip(self.groups, self.models, strict=True))


def group_name(model: ModelSpec) -> str:
    """The store group of a model: ``"<kind>-<model hash[:10]>"``."""
    return f"{model.kind}-{model_hash(model)[:10]}"


class Designed(Protocol):
    """What :func:`model_design` reads of a :class:`jobs.study.Study` (jobs.study imports
    this module: naming the class here would be an import cycle). Read-only properties:
    a study is a frozen dataclass."""

    @property
    def model(self) -> ModelSpec: ...

    @property
    def models(self) -> ModelsSpec | None: ...


def model_design(study: Designed) -> ModelDesign | None:
    """The study's design (None for a study without ``[models]``); deterministic."""
    spec = getattr(study, "models", None)
    return None if spec is None else design(study.model, spec)


# ------------------------------------------------------------------------------ parsing


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _leaf(base: ModelSpec, path: str, where: str) -> Any:
    """The value ``path`` names in ``base``'s canonical form (a number or a text)."""
    node: Any = base.editable_dict()
    parts = path.split(".")
    for k, part in enumerate(parts):
        if not isinstance(node, dict) or part not in node:
            here = ".".join(parts[:k])
            allowed = sorted(node) if isinstance(node, dict) else []
            hint = (f"; {here or 'the model'} has {', '.join(allowed)}" if allowed else
                    f"; {here} is a value, not a table")
            extra = (" (a cordless model has no reinforcement: start from "
                     'materials = "cord-reinforced")') if part == "reinforcement" else ""
            raise fail(where, f"names no model field{hint}{extra}")
        node = node[part]
    if isinstance(node, dict):
        raise fail(where, f"names a table, not a value: give one of its fields "
                   f"({', '.join(sorted(node))})")
    if not (_is_number(node) or isinstance(node, str)):
        raise fail(where, f"names a field that cannot be swept (holds {shown(node)})")
    return node


def _levels(value: Any, where: str, current: Any) -> tuple[Any, ...]:
    """Distinct values of the field's type (int fields: integers, text: strings)."""
    if not isinstance(value, list) or not value:
        raise fail(where, f"must be a non-empty list of values, got {shown(value)}")
    if len(value) > limits.MAX_VALUES:
        raise fail(where, f"{len(value)} values is too many (at most {limits.MAX_VALUES})")
    out: list[str | int | float] = []
    for k, x in enumerate(value):
        at = f"{where}[{k}]"
        if isinstance(current, str):
            out.append(scalars.string(x, at, "a text (the field is one)"))
        elif isinstance(current, int):
            out.append(scalars.integer(x, at))
        else:
            out.append(round(scalars.number(x, at), DIGITS))
    if len(set(out)) != len(out):
        raise fail(where, f"repeats a value: {shown(value)}")
    return tuple(out)


def _parameter(path: Any, value: Any, method: str, base: ModelSpec) -> Parameter:
    where = f'models.parameters."{path}"'
    if path in FIXED_FIELDS:
        raise fail(where, "cannot vary: a study has one model kind (write one study per kind)")
    current = _leaf(base, path, where)
    if isinstance(value, dict) and set(value) == {"levels"}:
        return Parameter(path, levels=_levels(value["levels"], f"{where}.levels", current))
    if method == "grid":
        if isinstance(current, float):  # a list, a {start, stop, step} range or a number
            return Parameter(path, levels=lists.values(value, where))
        if isinstance(current, int) and isinstance(value, dict):
            steps = lists.values(value, where)
            if not all(float(x).is_integer() for x in steps):
                raise fail(where, f"is an integer field; the range gives {list(steps)}")
            return Parameter(path, levels=tuple(int(x) for x in steps))
        return Parameter(path, levels=_levels(value, where, current))
    if not isinstance(current, float):
        raise fail(where, f"is {'a text' if isinstance(current, str) else 'an integer'} "
                   f"field: give {{ levels = [...] }} (sampled by index), got "
                   f"{shown(value)}")
    if isinstance(value, dict):
        scalars.table(value, where, {"levels"}, {"levels"})
    if not (isinstance(value, list) and len(value) == 2):
        raise fail(where, f"must be [low, high] or {{ levels = [...] }}, got {shown(value)}")
    low, high = (round(scalars.number(x, where), DIGITS) for x in value)
    if not low < high:
        raise fail(where, f"needs low < high, got {shown(value)}")
    return Parameter(path, low=low, high=high)


def parse_models(data: Any, base: ModelSpec, where: str = "models") -> ModelsSpec:
    """Validate a ``[models]`` table over the study's ``base`` model (no model is made)."""
    t = scalars.table(data, where, MODELS_KEYS, {"method", "parameters"})
    method = scalars.choice(t["method"], f"{where}.method", METHODS)
    if method == "grid":
        for key in ("n", "seed", "num_levels"):
            if key in t:
                raise fail(f"{where}.{key}", "is for sampled designs; a grid takes every "
                           "combination of the parameters' values")
        n = 0
    else:
        if "n" not in t:
            raise fail(f"{where}.n", f"is required for method = {method!r}")
        n = scalars.integer(t["n"], f"{where}.n", low=1, high=MAX_ROWS)
        if method == "sobol" and n & (n - 1):
            raise fail(f"{where}.n", f"must be a power of 2 for Sobol' sequences (their "
                       f"balance holds at 2^k points; SALib), got {n}")
    if "num_levels" in t and method != "morris":
        raise fail(f"{where}.num_levels", "is Morris' grid; only for method = 'morris'")
    num_levels = scalars.integer(t.get("num_levels", 4), f"{where}.num_levels", low=2, high=100)
    if num_levels % 2:  # Morris' jump p / (2 (p - 1)) keeps the levels symmetric only then
        raise fail(f"{where}.num_levels", f"must be even (SALib: an odd grid biases the "
                   f"sample), got {num_levels}")
    seed = scalars.integer(t.get("seed", 0), f"{where}.seed", low=0, high=limits.MAX_SEED)
    loads = scalars.choice(t.get("loads", "shared"), f"{where}.loads", LOADS)
    if loads == "own" and method in ("sobol", "morris"):
        raise fail(f"{where}.loads", f"'own' gives each model other load cases, and a "
                   f"{method} design's indices compare models under the same ones: use "
                   "method = 'lhs' (a population) or loads = 'shared'")
    params = scalars.table(t["parameters"], f"{where}.parameters", set(t["parameters"])
                           if isinstance(t["parameters"], dict) else set())
    if not params:
        raise fail(f"{where}.parameters", 'name at least one model field, e.g. '
                   '"materials.tread.youngs_modulus" = [2.0, 12.0]')
    spec = ModelsSpec(method, n, seed,
                      tuple(_parameter(p, x, method, base) for p, x in params.items()),
                      num_levels, loads)
    if spec.rows > MAX_ROWS:
        raise fail(where, f"a design of {spec.rows} models is too many (at most {MAX_ROWS})")
    return spec


# ----------------------------------------------------------------------------- sampling


def unit_sample(spec: ModelsSpec) -> np.ndarray:
    """The design in the unit hypercube, shape (rows, D), rows in the sampler's order.

    SALib scales its unit samples linearly to the problem's bounds, so sampling the unit
    problem and scaling here gives SALib's own rows (and lets levels map by index).
    """
    d = len(spec.parameters)
    unit = {"num_vars": d, "names": [p.path for p in spec.parameters], "bounds": [[0, 1]] * d}
    if spec.method == "lhs":
        return qmc.LatinHypercube(d=d, seed=spec.seed).random(spec.n)
    if spec.method == "sobol":
        from SALib.sample import sobol

        return sobol.sample(unit, spec.n, calc_second_order=False, scramble=True,
                            seed=spec.seed)
    if spec.method == "morris":
        from SALib.sample import morris

        return morris.sample(unit, spec.n, num_levels=spec.num_levels, seed=spec.seed)
    raise ValueError(f"no unit sample for method {spec.method!r}")  # grid: see _rows


def sobol_level(u: float, k: int, strata: np.ndarray) -> int:
    """The level index (0..k-1) a Sobol' coordinate ``u`` picks: the relabelled stratum.

    ``strata`` is a permutation of ``range(N)``, N the design's base sample size: ``u``'s
    stratum ``floor(u N)`` becomes ``strata[...]``, whose share of N gives the level.
    Why not ``floor(u k)``: see the module note (A and B share first digits).
    """
    n = len(strata)
    s = min(math.floor(u * n), n - 1)
    return min(int(strata[s]) * k // n, k - 1)


def level_strata(spec: ModelsSpec, j: int) -> np.ndarray:
    """The stratum permutation of parameter ``j`` of a sobol design (seeded: deterministic)."""
    return np.random.default_rng([spec.seed, j]).permutation(spec.n)


def _rows(spec: ModelsSpec) -> list[tuple[Any, ...]]:
    """Each row's values (the fields' own types), in the design's order."""
    if spec.method == "grid":
        return list(itertools.product(*(p.choices for p in spec.parameters)))
    unit = np.clip(unit_sample(spec), 0.0, 1.0)
    strata = {j: level_strata(spec, j) for j, p in enumerate(spec.parameters)
              if p.levels is not None and spec.method == "sobol"}
    rows = []
    for u_row in unit:
        row = []
        for j, (p, u) in enumerate(zip(spec.parameters, u_row, strict=True)):
            if p.levels is None:
                low, high = p.span
                row.append(round(float(low + u * (high - low)), DIGITS))
                continue
            k = len(p.levels)
            if spec.method == "morris":
                index = round(u * (k - 1))
            elif spec.method == "sobol":
                index = sobol_level(u, k, strata[j])
            else:
                index = min(math.floor(u * k), k - 1)
            row.append(p.levels[int(index)])
        rows.append(tuple(row))
    return rows


def swapped_rows(spec: ModelsSpec, rows: list[tuple[Any, ...]]) -> dict[str, int]:
    """Per level parameter, the base rows (sobol) or trajectories (morris) in which the
    design's swap (A -> AB_j) or step actually changes its value."""
    d = len(spec.parameters)
    out = {}
    for j, p in enumerate(spec.parameters):
        if p.levels is None:
            continue
        if spec.method == "sobol":
            blocks = [rows[i:i + d + 2] for i in range(0, len(rows), d + 2)]
            out[p.path] = sum(b[0][j] != b[1 + j][j] for b in blocks)
        elif spec.method == "morris":
            blocks = [rows[i:i + d + 1] for i in range(0, len(rows), d + 1)]
            out[p.path] = sum(len({r[j] for r in b}) > 1 for b in blocks)
    return out


def check_swaps(spec: ModelsSpec, rows: list[tuple[Any, ...]]) -> None:
    """Refuse a design whose level parameter its own swaps (nearly) never move.

    Sobol': the count c of base rows whose A -> AB_j swap changes the level must be at
    least :data:`MIN_SWAPPED` and plausible for independent A and B (two-sided binomial
    test of c out of N at ``1 - 1/k``, :data:`SWAP_P_VALUE`). Morris: every trajectory
    must move every level parameter (a step that keeps the level is an elementary
    effect of 0 divided by a nonzero step). Raises one StudyError naming the parameter.
    """
    if spec.method not in ("sobol", "morris"):
        return
    from scipy.stats import binomtest

    for p in spec.parameters:
        if p.levels is None:
            continue
        c = swapped_rows(spec, rows)[p.path]
        where = f'models.parameters."{p.path}"'
        k = len(p.levels)
        if spec.method == "morris":
            if c < spec.n:
                raise StudyError(
                    f"{where}: the morris design (n = {spec.n}, num_levels = "
                    f"{spec.num_levels}, seed = {spec.seed}) moves it in {c} of {spec.n} "
                    f"trajectories only: its {p.allowed()} map several grid levels to one, so "
                    "a step that keeps the level would count as an effect of 0; give "
                    "num_levels >= the number of levels, or fewer levels")
            continue
        expected = spec.n * (1 - 1 / k)
        p_value = binomtest(c, spec.n, 1 - 1 / k).pvalue
        if c < MIN_SWAPPED or p_value < SWAP_P_VALUE:
            raise StudyError(
                f"{where}: the sobol design (n = {spec.n}, seed = {spec.seed}) changes its "
                f"level in {c} of {spec.n} base rows of Saltelli's A -> AB_j swap, where "
                f"independent draws of its {p.allowed()} would change it in about "
                f"{expected:g} (binomial p = {p_value:.2g}): its Sobol' indices would be 0 "
                "or biased by the design, not by the model; use another seed, more levels "
                "or a larger n")


def _overrides(names: tuple[str, ...], row: tuple[Any, ...]) -> dict:
    """Dotted paths -> the nested tables :func:`jobs.validate.spec_tables.override_model` merges."""
    out: dict = {}
    for path, value in zip(names, row, strict=True):
        *tables, leaf = path.split(".")
        node = out
        for t in tables:
            node = node.setdefault(t, {})
        node[leaf] = value
    return out


def _invalid(spec: ModelsSpec, k: int, row: tuple, error: StudyError) -> StudyError:
    """One line naming the parameter the model rejects, its value in the row and range."""
    text = str(error)
    named = [(p, x) for p, x in zip(spec.parameters, row, strict=True)
             if p.path in text or p.path.rsplit(".", 1)[-1] in text]
    shown = named or list(zip(spec.parameters, row, strict=True))
    what = "; ".join(f'"{p.path}" = {x!r} (the design\'s {p.allowed()})' for p, x in shown)
    return StudyError(f"models: row {k} of the {spec.method} design gives an invalid model: "
                      f"{what}: {text}")


@functools.lru_cache(maxsize=8)
def design(base: ModelSpec, spec: ModelsSpec) -> ModelDesign:
    """The design of ``spec`` over ``base``: matrix, models and groups (validated)."""
    names = tuple(p.path for p in spec.parameters)
    rows = _rows(spec)
    check_swaps(spec, rows)
    models, seen = [], {}
    for k, row in enumerate(rows):
        if row not in seen:
            try:
                seen[row] = spec_tables.override_model(base, _overrides(names, row), "models")
            except StudyError as e:
                raise _invalid(spec, k, row, e) from e
        models.append(seen[row])
    matrix = np.array([[x if p.numeric else p.choices.index(x)
                        for p, x in zip(spec.parameters, row, strict=True)] for row in rows],
                      dtype=float).reshape(len(rows), len(names))
    matrix.flags.writeable = False  # shared by the cache: nobody may change it
    return ModelDesign(spec.method, names, tuple(p.bounds for p in spec.parameters), spec.n,
                       spec.seed, matrix, tuple(models), tuple(group_name(m) for m in models))
