"""Scenes as files: a TOML scene description -> ``Scene`` plus run options (``t_end``, ``frame_dt``, ``out``).

This module owns the scene-file format, its validation (every refusal is a ``ValueError`` that
names the file, the line, the key and what to change) and its translation onto the scene
builders (``base.fluid_scene``, ``coupled.coupled_scene`` and the built-in scenes). It builds on
the host only; nothing here is traced. A general scene goes schema -> parse -> spec -> build:
``_SCHEMA`` lists each table's keys (type, unit, range, default), :func:`parse` checks a document
against it and returns a :class:`SceneSpec` of typed tables (``DomainSpec``, ``WaterSpec``,
``FixedSpec``, ``BlockSpec``, ``MaterialsSpec``, ``SphSpec``, ``CouplingSpec``, ``GaugeSpec``,
``RunupSpec``), and :func:`build` makes the ``Scene``.

Entry points: :func:`load` (``SceneFile``: scene + run options), :func:`load_scene` (the scene),
:func:`load_builtin` (a built-in scene by name with validated options, as the CLI uses).

Units: SI throughout -- metres, seconds, kg/m^3, degrees for angles (keys end in ``_deg``),
N/m for contact stiffnesses, Pa for ``penalty_modulus``; z points up, gravity is -9.81 m/s^2 in z.

Form (a): a built-in scene with options
---------------------------------------
::

    [scene]
    builtin = "sliding_wedge"          # one of `rockjax list`
    [scene.options]                    # keyword arguments of that builder (see its docstring)
    dx = 0.02
    block_density = 2500.0
    coupling = "penalty"               # enums as their string values
    [run]
    t_end = 2.0                        # s
    [output]
    frame_dt = 0.02                    # s
    out = "wedge.h5"                   # relative to the working directory

Option names are checked against the builder's signature (an unknown one is refused with the
accepted list), and values against its annotations (numbers, booleans, enum strings, lists for
tuple options).

Form (b): a general scene
------------------------
::

    [scene]
    name = "box_off_ramp"
    still_level = 0.3                  # m; default: the highest water `level` (or water box top)

    [domain]                           # the tank: walls on its faces, none on periodic axes
    lo = [0.0, 0.0, 0.0]               # m; sizes are rounded to whole multiples of dx
    hi = [2.0, 0.4, 0.8]
    periodic = [false, false, false]
    open_top = true                    # no wall on top; particles above hi stop the run

    [[water]]                          # union of regions; each: box (default the domain) and
    lo = [0.6, 0.0, 0.0]               # optional `level` (z <= level) and extra planes that
    hi = [2.0, 0.4, 0.8]               # keep n . (x - point) <= 0 (normal points out of the water)
    level = 0.3
    planes = [{ point = [0.6, 0, 0.3], normal = [-1, 0, 1] }]

    [[fixed]]                          # fixed geometry: wall particles, and a FIXED block where
    type = "plane"                     # the scene has moving blocks (convex shapes only)
    point = [0.6, 0.0, 0.3]            # plane: the solid is behind it, `normal` points to the water
    normal = [1.0, 0.0, 1.0]
    # type = "box": lo, hi.   type = "mesh": file (STL/OBJ/PLY/OFF, relative to this file),
    # scale (file units -> m), offset [m], convexity_tol; `block = false` keeps it walls only.

    [[block]]                          # a rock block
    shape = "box"                      # box (size = lx, ly, lz) | wedge (size = length, width,
    size = [0.2, 0.2, 0.1]             # height; right angle at its origin, legs along +x, +z)
    position = [0.3, 0.2, 0.5]         # | mesh (file, hull, scale, convexity_tol); centroid, m
    rotation_axis = [0.0, 1.0, 0.0]    # rotation about the centroid (right hand), degrees
    rotation_deg = 45.0
    velocity = [0.0, 0.0, 0.0]         # m/s
    density = 2500.0                   # kg/m^3
    motion = "dynamic"                 # or "fixed"
    locked = "y rx rz"                 # guided: these world translations / rotations held still

    [materials]                        # block contacts (blocks.make_blocks)
    friction_angle_deg = 20.0          # [0, 90)
    cohesion = 0.0                     # N per contact point
    # normal_stiffness, shear_stiffness [N/m], penalty_modulus [Pa], damping_ratio [-],
    # joint_water (default true with water: faces pressed together carry the still water's
    # hydrostatic pressure, blocks.joint_water)

    [sph]                              # the water (needed with [[water]])
    dx = 0.02                          # particle spacing, m
    scheme = "wcsph"                   # or "seed"; c0 [m/s] (default 10 x the largest expected
    # speed), h_factor and cfl (default: the scheme's), alpha, nu [m^2/s], delta, wall_viscosity (0 = free-slip walls and
    # blocks), skin_factor (Verlet skin / dx; default the scheme's, 0.3 with WCSPH, 0.6 with moving blocks),
    # rebuild_every; kernel,
    # viscosity, wall_model, density_diffusion, shifting ("none" or "fickian": particle shifting,
    # sph.shifting) (water-only scenes; with blocks the defaults hold);
    # seed_gradient ("spiky", the paper's, or "poly6": the seed scheme's pressure-gradient kernel)

    [coupling]                         # water <-> moving blocks
    method = "penalty"                 # or "boundary_particles", "boundary_integral"; stiffness [1/s^2],
                                       # damping [1/s], interaction_distance [m] (penalty, seed Eq 22;
                                       # default dx/2, dx/4 with the others); guard (boundary_particles: that penalty
                                       # within dx/4 of a face too, default true); guard_fixed
                                       # (the fixed blocks' faces too, default false)
    [[gauge]]                          # free-surface elevation at (x, y)
    name = "near"
    xy = [1.0, 0.2]
    bottom_z = 0.0                     # m; default the domain floor
    [runup]                            # run-up on a slope: a point on it and its outward normal
    point = [2.0, 0.2, 0.0]
    normal = [-0.5, 0.0, 0.866]
    x_min = 1.8                        # only water beyond this x counts
    [run]
    t_end = 2.0
    [output]
    frame_dt = 0.02
    out = "run.h5"

Without ``[[water]]`` the scene is blocks only (no SPH is traced). Without moving blocks it is
water only (no block code is traced; fixed geometry is wall particles). Water, walls and fixed
geometry are sampled on one cubic lattice (cell centres ``domain.lo + (i + 1/2) dx``), as the
built-in scenes are: water where the clearance to every wall is > 0.3 dx, ``ceil(2 h_factor)``
wall layers behind every wall face, no water within dx/4 of a moving block.
"""

from __future__ import annotations

import dataclasses
import enum
import inspect
import math
import os
import re
import typing
import warnings
from typing import Any, NoReturn

import numpy as np

from ..sph import schemes as _schemes
from ..sph.terms import names as _term_names
from ..types import Coupling
from .base import GRAVITY, Resolution, Scene, check_lattice_size, fluid_scene, lattice, scheme_resolution

try:  # Python >= 3.11
    import tomllib as _toml
except ModuleNotFoundError:  # pragma: no cover - Python 3.10 with tomli installed
    try:
        import tomli as _toml  # type: ignore[no-redef]
    except ModuleNotFoundError:
        _toml = None

__all__ = ["RunOptions", "SceneFile", "load", "load_scene", "load_builtin", "builtin_options", "parse", "build",
           "SceneSpec", "DomainSpec", "WaterSpec", "FixedSpec", "BlockSpec", "MaterialsSpec", "SphSpec", "CouplingSpec",
           "GaugeSpec", "RunupSpec"]


@dataclasses.dataclass(frozen=True)
class RunOptions:
    """How to run a scene file's scene: ``t_end`` [s], ``frame_dt`` [s], ``out`` (HDF5 path); None: unset."""

    t_end: float | None = None
    frame_dt: float | None = None
    out: str | None = None


@dataclasses.dataclass(frozen=True)
class SceneFile:
    """A loaded scene file: the ``scene``, its ``run`` options and the ``source`` (path or ``<text>``)."""

    scene: Scene
    run: RunOptions
    source: str


# ----------------------------------------------------------------------------------------------
# line numbers: tomllib gives none for keys, so scan the text for each key within its table
# ----------------------------------------------------------------------------------------------

_STRING = re.compile(r'"(?:[^"\\]|\\.)*"|\'[^\']*\'')


def _code(line: str) -> str:
    """The line with string contents emptied and the comment removed."""
    return _STRING.sub('""', line).split("#", 1)[0]


def _parts(dotted: str) -> list[str]:
    return [p.strip().strip('"').strip("'") for p in dotted.split(".")]


class _LineIndex:
    """Where each table and key is defined: ``("block", 2, "density") -> line`` (1-based)."""

    def __init__(self, text: str):
        self.index: dict[tuple, int] = {}
        counts: dict[tuple, int] = {}
        table: tuple = ()
        depth = 0
        for no, raw in enumerate(text.splitlines(), 1):
            line = _code(raw)
            if depth > 0:  # inside a multi-line array or inline table
                depth += line.count("[") + line.count("{") - line.count("]") - line.count("}")
                continue
            m = re.match(r"\s*\[\[(.+)\]\]\s*$", line)
            if m:
                parts = _parts(m.group(1))
                path = self._resolve(parts[:-1], counts) + (parts[-1],)  # the array itself is not indexed
                counts[path] = counts.get(path, -1) + 1
                table = path + (counts[path],)
                self.index.setdefault(table, no)
                self.index.setdefault(path, no)
                continue
            m = re.match(r"\s*\[(.+)\]\s*$", line)
            if m:
                table = self._resolve(_parts(m.group(1)), counts)
                self.index.setdefault(table, no)
                continue
            m = re.match(r"\s*([A-Za-z0-9_\-.\"' ]+?)\s*=(.*)$", line)
            if m:
                path = table + tuple(_parts(m.group(1)))
                self.index.setdefault(path, no)
                for k in range(len(table) + 1, len(path)):
                    self.index.setdefault(path[:k], no)
                v = m.group(2)
                depth = v.count("[") + v.count("{") - v.count("]") - v.count("}")

    @staticmethod
    def _resolve(parts, counts) -> tuple:
        out: tuple = ()
        for p in parts:
            out = out + (p,)
            if out in counts:  # a table inside the current element of an array of tables
                out = out + (counts[out],)
        return out

    def line(self, path: tuple) -> int | None:
        for k in range(len(path), 0, -1):
            if tuple(path[:k]) in self.index:
                return self.index[tuple(path[:k])]
        return None


class _Ctx:
    """Error reporting for one scene file: ``fail(path, message)`` raises with file, line and key."""

    def __init__(self, source: str, text: str, base_dir: str):
        self.source = source
        self.lines = _LineIndex(text)
        self.base_dir = base_dir

    def where(self, path: tuple) -> str:
        n = self.lines.line(path)
        return f"{self.source} line {n}" if n else self.source

    def fail(self, path: tuple, message: str) -> NoReturn:
        raise ValueError(f"{self.where(path)}: key `{_dotted(path)}`{_element(path)}: {message}")

    def fail_table(self, path: tuple, message: str) -> NoReturn:
        raise ValueError(f"{self.where(path)}: table `[{_dotted(path)}]`{_element(path)}: {message}")


def _dotted(path: tuple) -> str:
    return ".".join(str(p) for p in path if not isinstance(p, int))


def _element(path: tuple) -> str:
    ints = [(path[i - 1], p) for i, p in enumerate(path) if isinstance(p, int) and i > 0]
    if not ints or not isinstance(ints[0][0], str):
        return ""
    name, idx = ints[0]
    return f" ([[{name}]] #{idx + 1})"


# ----------------------------------------------------------------------------------------------
# key schema
# ----------------------------------------------------------------------------------------------

_REQUIRED = object()


@dataclasses.dataclass(frozen=True)
class _Key:
    kind: str  # float int bool str vec2 vec3 bool3 choice planes table
    default: Any = None
    unit: str = ""
    lo: float | None = None
    lo_open: bool = False
    hi: float | None = None
    hi_open: bool = False
    choices: tuple = ()
    hint: str = ""


def _num(kind="float", default=None, unit="", lo=None, lo_open=False, hi=None, hi_open=False, hint=""):
    return _Key(kind, default, unit, lo, lo_open, hi, hi_open, (), hint)


def _choice(choices, default=None):
    return _Key("choice", default, choices=tuple(choices))


_POS = dict(lo=0.0, lo_open=True)
_NONNEG = dict(lo=0.0)

_SCHEMA: dict[str, dict[str, _Key]] = {
    "scene": {"name": _Key("str"), "builtin": _Key("str"), "options": _Key("table"), "description": _Key("str"),
              "still_level": _num(unit="m")},
    "domain": {"lo": _Key("vec3", _REQUIRED, "m"), "hi": _Key("vec3", _REQUIRED, "m"),
               "periodic": _Key("bool3", (False, False, False)), "open_top": _Key("bool", True)},
    "water": {"lo": _Key("vec3", None, "m"), "hi": _Key("vec3", None, "m"), "level": _num(unit="m"),
              "planes": _Key("planes", ())},
    "fixed": {"type": _choice(("box", "plane", "mesh"), _REQUIRED), "name": _Key("str"),
              "lo": _Key("vec3", None, "m"), "hi": _Key("vec3", None, "m"), "point": _Key("vec3", None, "m"),
              "normal": _Key("vec3", None), "file": _Key("str"), "scale": _num(default=1.0, **_POS),
              "offset": _Key("vec3", (0.0, 0.0, 0.0), "m"), "convexity_tol": _num(default=1e-4, lo=0.0, hi=0.5),
              "block": _Key("bool", True)},
    "block": {"shape": _choice(("box", "wedge", "mesh"), _REQUIRED), "name": _Key("str"),
              "size": _Key("vec3", None, "m", lo=0.0, lo_open=True), "file": _Key("str"), "hull": _Key("bool", False),
              "scale": _num(default=1.0, **_POS), "convexity_tol": _num(default=1e-4, lo=0.0, hi=0.5),
              "position": _Key("vec3", None, "m"), "rotation_axis": _Key("vec3", (0.0, 0.0, 1.0)),
              "rotation_deg": _num(default=0.0, unit="degrees"), "velocity": _Key("vec3", (0.0, 0.0, 0.0), "m/s"),
              "density": _num(default=2650.0, unit="kg/m^3", **_POS,
                              hint="rock is ~2000-3000 kg/m^3"),
              "motion": _choice(("dynamic", "fixed"), "dynamic"), "locked": _Key("str", "")},
    "materials": {"friction_angle_deg": _num(default=30.0, unit="degrees", lo=0.0, hi=90.0, hi_open=True),
                  "cohesion": _num(default=0.0, unit="N", **_NONNEG),
                  "normal_stiffness": _num(unit="N/m", **_POS), "shear_stiffness": _num(unit="N/m", **_POS),
                  "penalty_modulus": _num(default=1e9, unit="Pa", **_POS),
                  "damping_ratio": _num(default=0.2, **_NONNEG), "joint_water": _Key("bool", True)},
    "rock_mass": {"lo": _Key("vec3", _REQUIRED, "m"), "hi": _Key("vec3", _REQUIRED, "m"),
                  "planes": _Key("planes", ()), "density": _num(default=2650.0, unit="kg/m^3", **_POS,
                                                               hint="rock is ~2000-3000 kg/m^3"),
                  "min_volume": _num(unit="m^3", **_NONNEG), "motion": _choice(("dynamic", "fixed"), "dynamic")},
    "joint_set": {"dip_deg": _num(default=_REQUIRED, unit="degrees", lo=0.0, hi=90.0),
                  "dip_direction_deg": _num(default=_REQUIRED, unit="degrees", lo=-360.0, hi=360.0),
                  "spacing": _num(default=_REQUIRED, unit="m", **_POS), "offset": _num(default=0.0, unit="m"),
                  "jitter": _num(default=0.0, lo=0.0, hi=1.0, hi_open=True), "seed": _num("int", 0)},
    "gauge": {"name": _Key("str"), "xy": _Key("vec2", _REQUIRED, "m"), "bottom_z": _num(unit="m")},
    "runup": {"point": _Key("vec3", _REQUIRED, "m"), "normal": _Key("vec3", _REQUIRED), "x_min": _num(unit="m")},
    "output": {"frame_dt": _num(unit="s", **_POS), "out": _Key("str")},
    "run": {"t_end": _num(unit="s", **_POS)},
    "sph": {"dx": _num(unit="m", **_POS, hint="the particle spacing, e.g. dx = 0.02"),
            "scheme": _choice(tuple(_term_names("scheme")), "wcsph"), "c0": _num(unit="m/s", **_POS),
            "h_factor": _num(lo=0.5, hi=3.0), "alpha": _num(**_NONNEG),
            "nu": _num(unit="m^2/s", **_NONNEG), "delta": _num(default=0.1, **_NONNEG),
            "wall_viscosity": _num(default=1.0, **_NONNEG),
            "skin_factor": _num(**_NONNEG), "rebuild_every": _num("int", 8, lo=1),
            "cfl": _num(lo=0.0, lo_open=True, hi=1.0),
            "kernel": _choice(tuple(_term_names("kernel"))),
            "viscosity": _choice(tuple(_term_names("viscosity"))),
            "wall_model": _choice(tuple(_term_names("walls"))),
            "density_diffusion": _choice(tuple(_term_names("diffusion"))),
            "shifting": _choice(tuple(_term_names("shifting"))),
            "seed_gradient": _choice(tuple(_term_names("seed_gradient")))},
    "coupling": {"method": _choice(("penalty", "boundary_particles", "boundary_integral"), "penalty"),
                 "stiffness": _num(unit="1/s^2", **_POS), "damping": _num(unit="1/s", **_NONNEG),
                 "interaction_distance": _num(unit="m", **_POS), "guard": _Key("bool", True),
                 "guard_fixed": _Key("bool", False)},
}
_ARRAYS = ("water", "fixed", "block", "gauge", "joint_set")
_FIXED_KEYS = {"box": {"lo", "hi"}, "plane": {"point", "normal"}, "mesh": {"file", "scale", "offset", "convexity_tol"}}
_BLOCK_KEYS = {"box": {"size"}, "wedge": {"size"}, "mesh": {"file", "hull", "scale", "convexity_tol"}}
_BUILTIN_TABLES = ("scene", "run", "output")


def _typename(v) -> str:
    return {bool: "boolean", int: "integer", float: "number", str: "string", list: "array",
            dict: "table"}.get(type(v), type(v).__name__)


def _range_text(k: _Key) -> str:
    parts = []
    if k.lo is not None:
        parts.append(f"{'>' if k.lo_open else '>='} {k.lo:g}")
    if k.hi is not None:
        parts.append(f"{'<' if k.hi_open else '<='} {k.hi:g}")
    return " and ".join(parts)


def _in_range(k: _Key, x: float) -> bool:
    if k.lo is not None and (x <= k.lo if k.lo_open else x < k.lo):
        return False
    if k.hi is not None and (x >= k.hi if k.hi_open else x > k.hi):
        return False
    return True


def _number(ctx: _Ctx, path, v, k: _Key, *, integer=False) -> float:
    unit = f" ({k.unit})" if k.unit else ""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)):
        what = "an integer" if integer else "a number"
        ctx.fail(path, f"expected {what}{unit}, got {_typename(v)} {v!r}; write e.g. `{path[-1]} = "
                       f"{k.default if isinstance(k.default, (int, float)) and not isinstance(k.default, bool) else 1.0}`")
    if not math.isfinite(v):
        ctx.fail(path, f"must be finite{unit} (got {v})")
    if not _in_range(k, v):
        hint = f"; {k.hint}" if k.hint else ""
        ctx.fail(path, f"must be {_range_text(k)}{' ' + k.unit if k.unit else ''} (got {v}){hint}")
    return int(v) if integer else float(v)


def _vector(ctx: _Ctx, path, v, k: _Key, n: int) -> tuple:
    unit = f" in {k.unit}" if k.unit else ""
    if not isinstance(v, list) or len(v) != n:
        ctx.fail(path, f"expected an array of {n} numbers{unit}, got {_typename(v)} {v!r}")
    out = []
    for x in v:
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
            ctx.fail(path, f"expected an array of {n} finite numbers{unit}, got {v!r}")
        if not _in_range(k, x):
            ctx.fail(path, f"every component must be {_range_text(k)}{' ' + k.unit if k.unit else ''} (got {v!r})")
        out.append(float(x))
    return tuple(out)


def _value(ctx: _Ctx, path: tuple, v, k: _Key):
    if k.kind == "float":
        return _number(ctx, path, v, k)
    if k.kind == "int":
        return _number(ctx, path, v, k, integer=True)
    if k.kind == "bool":
        if not isinstance(v, bool):
            ctx.fail(path, f"expected true or false, got {_typename(v)} {v!r}")
        return v
    if k.kind == "str":
        if not isinstance(v, str):
            ctx.fail(path, f"expected a string, got {_typename(v)} {v!r}; quote it: `{path[-1]} = \"...\"`")
        return v
    if k.kind == "choice":
        if not isinstance(v, str) or v not in k.choices:
            ctx.fail(path, f"must be one of {', '.join(repr(c) for c in k.choices)} (got {v!r})")
        return v
    if k.kind == "vec3":
        return _vector(ctx, path, v, k, 3)
    if k.kind == "vec2":
        return _vector(ctx, path, v, k, 2)
    if k.kind == "bool3":
        if not isinstance(v, list) or len(v) != 3 or not all(isinstance(b, bool) for b in v):
            ctx.fail(path, f"expected an array of 3 booleans (x, y, z), got {v!r}")
        return tuple(v)
    if k.kind == "table":
        if not isinstance(v, dict):
            ctx.fail(path, f"expected a table, got {_typename(v)} {v!r}")
        return v
    if k.kind == "planes":
        if not isinstance(v, list):
            ctx.fail(path, "expected an array of inline tables { point = [x, y, z], normal = [nx, ny, nz] }")
        out = []
        for i, p in enumerate(v):
            if not isinstance(p, dict) or set(p) != {"point", "normal"}:
                ctx.fail(path, f"plane #{i + 1} must be {{ point = [x, y, z], normal = [nx, ny, nz] }} (got {p!r})")
            point = _vector(ctx, path, p["point"], _Key("vec3", unit="m"), 3)
            normal = _vector(ctx, path, p["normal"], _Key("vec3"), 3)
            if not np.linalg.norm(normal) > 0:
                ctx.fail(path, f"plane #{i + 1}: normal must be a non-zero vector")
            out.append((point, normal))
        return tuple(out)
    raise AssertionError(k.kind)  # pragma: no cover


def _table(ctx: _Ctx, path: tuple, data, schema: dict[str, _Key]) -> dict:
    """Check one table against its schema: unknown keys, types, ranges, required keys; fill defaults."""
    if not isinstance(data, dict):
        ctx.fail(path, f"expected a table (`[{_dotted(path)}]`), got {_typename(data)}")
    for key in data:
        if key not in schema:
            ctx.fail(path + (key,), f"unknown key; accepted keys in [{_dotted(path)}]: {', '.join(schema)}")
    out = {}
    for key, k in schema.items():
        if key in data:
            out[key] = _value(ctx, path + (key,), data[key], k)
        elif k.default is _REQUIRED:
            ctx.fail_table(path, f"the key `{key}` is required")
        else:
            out[key] = k.default
    return out


# ----------------------------------------------------------------------------------------------
# loading
# ----------------------------------------------------------------------------------------------


def _read(path_or_text) -> tuple[str, str, str]:
    """(source name, text, base directory for relative paths)."""
    if isinstance(path_or_text, os.PathLike) or (
            isinstance(path_or_text, str) and "\n" not in path_or_text and "=" not in path_or_text):
        path = os.fspath(path_or_text)
        if not os.path.isfile(path):
            raise ValueError(f"scene file {path!r} does not exist")
        with open(path, encoding="utf-8") as f:
            text = f.read()
        return path, text, os.path.dirname(os.path.abspath(path))
    if not isinstance(path_or_text, str):
        raise ValueError(f"load: expected a path or TOML text, got {type(path_or_text).__name__}")
    return "<scene text>", path_or_text, os.getcwd()


def _parse(source: str, text: str) -> dict:
    if _toml is None:  # pragma: no cover
        raise ValueError("reading scene files needs Python >= 3.11 (tomllib) or the `tomli` package")
    try:
        return _toml.loads(text)
    except _toml.TOMLDecodeError as exc:
        raise ValueError(f"{source}: not valid TOML: {exc}") from exc


def load(path_or_text, *, dx: float | None = None, scheme: str | None = None,
         coupling: str | None = None) -> SceneFile:
    """Load a scene file (a path, or TOML text) and build its scene.

    Args:
        path_or_text: a ``.toml`` path (``str`` or ``os.PathLike``) or the TOML text itself.
        dx: override the particle spacing [m] (``sph.dx``, or the builder's ``dx`` option).
        scheme, coupling: override the SPH scheme / coupling method (string values).

    Returns:
        ``SceneFile(scene, run, source)``; ``scene.meta["scene_file"]`` holds the source.

    Raises:
        ValueError: ``"<file> line N: key `table.key`: what is wrong; what to change"``.
    """
    source, text, base = _read(path_or_text)
    doc = _parse(source, text)
    ctx = _Ctx(source, text, base)
    scene_t = doc.get("scene", {})
    if not isinstance(scene_t, dict):
        ctx.fail(("scene",), "expected a table [scene]")
    overrides = {k: v for k, v in (("dx", dx), ("scheme", scheme), ("coupling", coupling)) if v is not None}
    if "builtin" in scene_t:
        scene = _load_builtin_form(ctx, doc, overrides)
    else:
        scene = _load_general(ctx, doc, overrides)
    run_t = _table(ctx, ("run",), doc.get("run", {}), _SCHEMA["run"])
    out_t = _table(ctx, ("output",), doc.get("output", {}), _SCHEMA["output"])
    scene = scene.replace(meta=scene.meta.with_items(scene_file=source))
    return SceneFile(scene=scene, run=RunOptions(t_end=run_t["t_end"], frame_dt=out_t["frame_dt"], out=out_t["out"]),
                     source=source)


def load_scene(path_or_text, *, dx: float | None = None, scheme: str | None = None,
               coupling: str | None = None) -> Scene:
    """The ``Scene`` of a scene file (see :func:`load`; run options are dropped)."""
    return load(path_or_text, dx=dx, scheme=scheme, coupling=coupling).scene


# ---- form (a): built-in scene + options --------------------------------------------------------


def builtin_options(name: str) -> dict[str, Any]:
    """The options of built-in scene ``name``: ``{option: default}`` (keyword arguments of its builder)."""
    from . import BUILTIN

    if name not in BUILTIN:
        raise ValueError(f"unknown built-in scene {name!r}; one of: {', '.join(BUILTIN)}")
    return {p.name: p.default for p in inspect.signature(BUILTIN[name]).parameters.values()}


def _hint_types(hint) -> tuple:
    if hint is None:
        return ()
    args = typing.get_args(hint)
    return tuple(a for a in args if a is not type(None)) if args else (hint,)


def _builtin_value(ctx: _Ctx, path: tuple, v, hint, default):
    types = _hint_types(hint)
    if isinstance(default, _schemes.FluidScheme):  # a name, or a table {scheme = "wcsph", diffusion = "antuono"}
        if isinstance(v, _schemes.FluidScheme):
            return v
        table = {"scheme": v} if isinstance(v, str) else v
        if not isinstance(table, dict):
            ctx.fail(path, f'expected a scheme name ("wcsph", "seed") or a table of its terms, got {_typename(v)} {v!r}')
        try:
            return _schemes.from_names(**table)
        except (TypeError, ValueError) as exc:
            ctx.fail(path, f"{exc} (keys: scheme, kernel, viscosity, walls, diffusion, shifting, gradient)")
    enum_cls = next((t for t in types if isinstance(t, type) and issubclass(t, enum.Enum)), None)
    if enum_cls is None and isinstance(default, enum.Enum):
        enum_cls = type(default)
    if enum_cls is not None:
        if isinstance(v, enum_cls):
            return v
        choices = tuple(m.value for m in enum_cls)
        if not isinstance(v, str) or v not in choices:
            ctx.fail(path, f"must be one of {', '.join(repr(c) for c in choices)} (got {v!r})")
        return enum_cls(v)
    if bool in types or isinstance(default, bool):
        if not isinstance(v, bool):
            ctx.fail(path, f"expected true or false, got {_typename(v)} {v!r}")
        return v
    if float in types or (isinstance(default, float) and not types):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            ctx.fail(path, f"expected a number (SI units), got {_typename(v)} {v!r}")
        if not math.isfinite(v):
            ctx.fail(path, f"must be finite (got {v})")
        return float(v)
    if int in types or (isinstance(default, int) and not types):
        if isinstance(v, bool) or not isinstance(v, int):
            ctx.fail(path, f"expected an integer, got {_typename(v)} {v!r}")
        return v
    if dict in types:
        if not isinstance(v, dict):
            ctx.fail(path, f"expected a table, got {_typename(v)} {v!r}")
        return v
    if isinstance(default, tuple):
        if not isinstance(v, list) or len(v) != len(default) or not all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v):
            ctx.fail(path, f"expected an array of {len(default)} finite numbers (like the default {list(default)}), "
                           f"got {v!r}")
        return tuple(float(x) for x in v)
    if isinstance(v, list):  # e.g. gauge_x = [0.3, 0.6]
        return list(v)
    return v


def _builder_kwargs(ctx: _Ctx, name: str, options: dict, overrides: dict) -> dict:
    from . import BUILTIN

    builder = BUILTIN[name]
    params = inspect.signature(builder).parameters
    hints = typing.get_type_hints(builder)
    accepted = ", ".join(params)
    kwargs = {}
    for key, v in options.items():
        path = ("scene", "options", key)
        if key not in params:
            ctx.fail(path, f"unknown option of built-in scene {name!r}; accepted: {accepted}")
        kwargs[key] = _builtin_value(ctx, path, v, hints.get(key), params[key].default)
        if key.endswith("_file") and isinstance(kwargs[key], str) and kwargs[key]:
            kwargs[key] = _path_in(ctx, path, kwargs[key])  # relative to the scene file
    for key, v in overrides.items():
        if key not in params:
            raise ValueError(f"scene {name!r} has no option --{key} (its options: {accepted})")
        kwargs[key] = _builtin_value(ctx, ("scene", "options", key), v, hints.get(key), params[key].default)
    return kwargs


def _call_builder(ctx: _Ctx, name: str, kwargs: dict) -> Scene:
    from . import BUILTIN

    try:
        return BUILTIN[name](**kwargs)
    except ValueError as exc:
        named = [k for k in kwargs if re.search(rf"\b{re.escape(k)}\b", str(exc))]
        path = ("scene", "options", named[0]) if named else ("scene", "builtin")
        raise ValueError(f"{ctx.where(path)}: key `{_dotted(path)}`: {exc}") from exc


def _load_builtin_form(ctx: _Ctx, doc: dict, overrides: dict) -> Scene:
    from . import BUILTIN

    for table in doc:
        if table not in _BUILTIN_TABLES:
            path = (table,) + ((0,) if isinstance(doc[table], list) else ())
            ctx.fail_table(path, f"not used with `builtin` scenes (only {', '.join(_BUILTIN_TABLES)}); put the "
                                 "builder's keyword arguments under [scene.options], or drop `builtin` to describe "
                                 "a general scene")
    scene_t = doc["scene"]
    for key in scene_t:
        if key not in ("builtin", "options", "description"):
            ctx.fail(("scene", key), "unknown key with `builtin`; accepted: builtin, options, description")
    name = _value(ctx, ("scene", "builtin"), scene_t["builtin"], _Key("str"))
    if name not in BUILTIN:
        ctx.fail(("scene", "builtin"), f"unknown built-in scene {name!r}; one of: {', '.join(BUILTIN)}")
    options = _value(ctx, ("scene", "options"), scene_t.get("options", {}), _Key("table"))
    return _call_builder(ctx, name, _builder_kwargs(ctx, name, options, overrides))


def load_builtin(name: str, *, dx: float | None = None, scheme: str | None = None, coupling: str | None = None,
                 **options) -> Scene:
    """Built-in scene ``name`` with ``options`` checked as a scene file's ``[scene.options]`` are
    (unknown option -> ValueError listing the accepted ones; enums may be given as strings)."""
    from . import BUILTIN

    if name not in BUILTIN:
        raise ValueError(f"unknown scene {name!r}; `rockjax list` shows the built-in scenes ({', '.join(BUILTIN)})")
    ctx = _Ctx(f"scene {name!r}", "", os.getcwd())
    overrides = {k: v for k, v in (("dx", dx), ("scheme", scheme), ("coupling", coupling)) if v is not None}
    return _call_builder(ctx, name, _builder_kwargs(ctx, name, options, overrides))


# ---- form (b): a general scene -----------------------------------------------------------------


def _rotation(axis, angle_deg: float) -> np.ndarray:
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    t = math.radians(angle_deg)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K


def _path_in(ctx: _Ctx, path: tuple, value: str) -> str:
    return value if os.path.isabs(value) else os.path.join(ctx.base_dir, value)


def _check_type_keys(ctx: _Ctx, path: tuple, data: dict, kind_key: str, kind: str, per_kind: dict,
                     required: dict) -> None:
    own = per_kind[kind]
    other = set().union(*per_kind.values()) - own
    for key in data:
        if key in other:
            ctx.fail(path + (key,), f"does not apply to {kind_key} = {kind!r} (its keys: {', '.join(sorted(own))})")
    for key in required.get(kind, ()):
        if key not in data:
            ctx.fail_table(path, f"{kind_key} = {kind!r} needs the key `{key}`")


# The general form goes schema -> parse -> spec -> build: ``parse`` checks the document against
# ``_SCHEMA`` and the rules between tables (every refusal names the key and its line) and returns a
# ``SceneSpec`` of typed tables; ``build`` turns a spec into a ``Scene`` (lattice, walls, water,
# blocks) through ``base.fluid_scene`` / ``coupled.coupled_scene``. Refusals that need the geometry
# (a water region without particles, a block inside fixed geometry, a mesh file that fails) come
# from ``build``, through the spec's error reporter, with the key and line too.

Vec3 = tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class DomainSpec:
    """``[domain]``: the tank box ``lo``..``hi`` [m] (walls on its faces), ``periodic`` axes (no wall
    on their faces), ``open_top`` (no wall on top)."""

    lo: Vec3
    hi: Vec3
    periodic: tuple[bool, bool, bool] = (False, False, False)
    open_top: bool = True


@dataclasses.dataclass(frozen=True)
class WaterSpec:
    """One ``[[water]]`` region: the box ``lo``..``hi`` [m] (None: the domain's), below ``level``
    [m] if given, and inside ``planes`` (``(point, normal)`` pairs, normal out of the water)."""

    lo: Vec3 | None
    hi: Vec3 | None
    level: float | None
    planes: tuple
    path: tuple  # ("water", i): where the file defines it


@dataclasses.dataclass(frozen=True)
class FixedSpec:
    """One ``[[fixed]]`` solid: ``type`` box (``lo``, ``hi``), plane (``point``, ``normal`` [m]) or mesh
    (``file``, a path resolved against the scene file's folder; ``scale``, ``offset`` [m],
    ``convexity_tol``); ``block``: also a FIXED block when the scene has moving blocks."""

    type: str
    name: str
    lo: Vec3 | None
    hi: Vec3 | None
    point: Vec3 | None
    normal: Vec3 | None
    file: str | None
    scale: float
    offset: Vec3
    convexity_tol: float
    block: bool
    path: tuple


@dataclasses.dataclass(frozen=True)
class BlockSpec:
    """One ``[[block]]``: ``shape`` box / wedge (``size`` [m]) or mesh (``file``, ``hull``, ``scale``,
    ``convexity_tol``), placed with its centroid at ``position`` [m] (None: the mesh's own) after a
    rotation of ``rotation_deg`` about ``rotation_axis``; ``velocity`` [m/s], ``density`` [kg/m^3],
    ``motion`` ("dynamic" or "fixed"); ``locked``: degrees of freedom held still (``x y z rx ry rz``,
    e.g. ``"y rx rz"`` for a slide guided in the x-z plane; ``make_blocks(locked=...)``)."""

    shape: str
    name: str | None
    size: Vec3 | None
    file: str | None
    hull: bool
    scale: float
    convexity_tol: float
    position: Vec3 | None
    rotation_axis: Vec3
    rotation_deg: float
    velocity: Vec3
    density: float
    motion: str
    path: tuple
    polyhedron: Any = None  # a block cut from the [rock_mass], placed (shape "rock")
    locked: str = ""


@dataclasses.dataclass(frozen=True)
class MaterialsSpec:
    """``[materials]``: the block contacts (``blocks.make_blocks``); None: the builder's default."""

    friction_angle_deg: float
    cohesion: float
    normal_stiffness: float | None
    shear_stiffness: float | None
    penalty_modulus: float
    damping_ratio: float
    joint_water: bool

    def block_kwargs(self) -> dict:
        """The contact keywords for ``coupled_scene(block_kwargs=...)`` (unset ones left out)."""
        return {k: getattr(self, k) for k in ("cohesion", "normal_stiffness", "shear_stiffness", "penalty_modulus",
                                               "damping_ratio") if getattr(self, k) is not None}


@dataclasses.dataclass(frozen=True)
class SphSpec:
    """``[sph]``: the particle spacing ``dx`` [m] (None: blocks only), the fluid scheme object
    ``scheme`` (None without water) and the constants given to the builders; ``alpha`` and ``nu``
    [m^2/s] are the scheme's defaults where the file gives none; ``skin_factor`` None: the
    builders' default (0.3 dx for water only, 0.6 dx with moving blocks)."""

    dx: float | None
    scheme: Any
    c0: float | None
    h_factor: float
    alpha: float | None
    nu: float | None
    delta: float
    wall_viscosity: float
    skin_factor: float | None
    rebuild_every: int
    cfl: float


@dataclasses.dataclass(frozen=True)
class CouplingSpec:
    """``[coupling]``: the ``method`` (``Coupling``) and the seed Eq 22 penalty's ``stiffness``
    [1/s^2], ``damping`` [1/s] and ``interaction_distance`` [m] (None: ``coupling_params``'
    defaults); ``guard`` and ``guard_fixed`` (``Config.coupling_guard`` / ``guard_fixed``)."""

    method: Coupling
    stiffness: float | None
    damping: float | None
    interaction_distance: float | None
    guard: bool
    guard_fixed: bool


@dataclasses.dataclass(frozen=True)
class GaugeSpec:
    """One ``[[gauge]]``: ``name``, position ``xy`` [m], the bed ``bottom_z`` [m] (None: the domain floor)."""

    name: str | None
    xy: tuple[float, float]
    bottom_z: float | None


@dataclasses.dataclass(frozen=True)
class RunupSpec:
    """``[runup]``: a ``point`` [m] on the slope, its outward unit ``normal``, ``x_min`` [m] (None: all water)."""

    point: Vec3
    normal: Vec3
    x_min: float | None


@dataclasses.dataclass(frozen=True)
class SceneSpec:
    """A general scene file, checked: every table typed, defaults filled, overrides applied.

    ``where`` reports the refusals that only ``build`` can find with the file, line and key.
    """

    name: str
    description: str | None
    still_level: float | None
    domain: DomainSpec | None
    waters: tuple[WaterSpec, ...]
    fixed: tuple[FixedSpec, ...]
    blocks: tuple[BlockSpec, ...]
    materials: MaterialsSpec
    sph: SphSpec
    coupling: CouplingSpec
    gauges: tuple[GaugeSpec, ...]
    runup: RunupSpec | None
    where: _Ctx = dataclasses.field(repr=False, compare=False)
    rock_mass: dict | None = None  # the [rock_mass]'s cut: RockMass.size_distribution()

    @property
    def moving(self) -> tuple[BlockSpec, ...]:
        """The dynamic blocks."""
        return tuple(b for b in self.blocks if b.motion == "dynamic")


def _fields(cls, table: dict, **more):
    """``cls`` from a checked table (its keys that are fields of ``cls``) and ``more``."""
    names = {f.name for f in dataclasses.fields(cls)}
    return cls(**{k: v for k, v in table.items() if k in names}, **more)


def _array_tables(ctx: _Ctx, doc: dict, name: str) -> list:
    raw = doc.get(name, [])
    if not isinstance(raw, list):
        ctx.fail_table((name,), f"write it as an array of tables: [[{name}]]")
    return [_table(ctx, (name, i), d, _SCHEMA[name]) for i, d in enumerate(raw)]


def _parse_fixed(ctx: _Ctx, doc: dict, has_domain: bool) -> tuple[FixedSpec, ...]:
    out = []
    for i, data in enumerate(doc.get("fixed", [])):
        path = ("fixed", i)
        f = _table(ctx, path, data, _SCHEMA["fixed"])
        kind = f["type"]
        _check_type_keys(ctx, path, data, "type", kind, _FIXED_KEYS,
                         {"box": ("lo", "hi"), "plane": ("point", "normal"), "mesh": ("file",)})
        if kind == "box" and not all(h > l for l, h in zip(f["lo"], f["hi"])):
            ctx.fail(path + ("hi",), f"must exceed lo on every axis (lo {list(f['lo'])}, hi {list(f['hi'])})")
        if kind == "plane":
            if not np.linalg.norm(f["normal"]) > 0:
                ctx.fail(path + ("normal",), "must be a non-zero vector (pointing out of the solid, into the water)")
            if not has_domain:
                ctx.fail_table(path, "type = 'plane' needs a [domain] to bound it")
        f["name"] = f["name"] or f"fixed #{i + 1} ({kind})"
        if f["file"] is not None:
            f["file"] = _path_in(ctx, path, f["file"])
        out.append(_fields(FixedSpec, f, path=path))
    return tuple(out)


def _parse_blocks(ctx: _Ctx, doc: dict) -> tuple[BlockSpec, ...]:
    out = []
    for i, data in enumerate(doc.get("block", [])):
        path = ("block", i)
        b = _table(ctx, path, data, _SCHEMA["block"])
        _check_type_keys(ctx, path, data, "shape", b["shape"], _BLOCK_KEYS,
                         {"box": ("size", "position"), "wedge": ("size", "position"), "mesh": ("file",)})
        if not np.linalg.norm(b["rotation_axis"]) > 0:
            ctx.fail(path + ("rotation_axis",), "must be a non-zero vector")
        if b["file"] is not None:
            b["file"] = _path_in(ctx, path, b["file"])
        if b["locked"]:
            from ..blocks.model import _DOF_NAMES

            names = b["locked"].replace(",", " ").split()
            bad = [n for n in names if n not in _DOF_NAMES]
            if bad:
                ctx.fail(path + ("locked",), f"unknown degrees of freedom {bad}; use names from {list(_DOF_NAMES)} "
                                            f"(e.g. \"y rx rz\" for a slide guided in the x-z plane)")
            if len(set(names)) == 6:
                ctx.fail(path + ("locked",), "all six degrees of freedom are locked; use motion = \"fixed\"")
            if b["motion"] != "dynamic":
                ctx.fail(path + ("locked",), "only a dynamic block can be guided; remove locked or set motion = \"dynamic\"")
        out.append(_fields(BlockSpec, b, path=path))
    return tuple(out)


def _parse_rock_mass(ctx: _Ctx, doc: dict) -> tuple[tuple[BlockSpec, ...], dict | None]:
    """``[rock_mass]`` cut along the ``[[joint_set]]`` planes (``blocks.cutting``): one BlockSpec per
    block (shape "rock", its polyhedron placed) and the cut's size distribution."""
    from ..blocks import cutting

    sets_t = _array_tables(ctx, doc, "joint_set")
    if "rock_mass" not in doc:
        if sets_t:
            ctx.fail_table(("joint_set", 0), "joint sets cut a rock mass: add [rock_mass] (lo, hi, planes)")
        return (), None
    rm = _table(ctx, ("rock_mass",), doc["rock_mass"], _SCHEMA["rock_mass"])
    try:
        domain = cutting.region(rm["lo"], rm["hi"], rm["planes"])
    except ValueError as exc:
        ctx.fail(("rock_mass", "planes" if rm["planes"] else "hi"), str(exc))
    sets = []
    for i, js in enumerate(sets_t):
        try:
            sets.append(cutting.JointSet(js["dip_deg"], js["dip_direction_deg"], js["spacing"], offset=js["offset"],
                                         jitter=js["jitter"], seed=js["seed"]))
        except ValueError as exc:
            ctx.fail(("joint_set", i), str(exc))
    rock = cutting.cut(domain, sets, min_volume=rm["min_volume"])
    if rock.n_blocks == 0:
        ctx.fail(("rock_mass", "min_volume"), "every block is below min_volume; lower it or widen the spacings")
    out = tuple(BlockSpec(shape="rock", name=f"rock {k + 1}", size=None, file=None, hull=False, scale=1.0,
                          convexity_tol=0.0, position=tuple(map(float, poly.centroid_world)),
                          rotation_axis=(0.0, 0.0, 1.0), rotation_deg=0.0, velocity=(0.0, 0.0, 0.0),
                          density=rm["density"], motion=rm["motion"], path=("rock_mass",), polyhedron=poly)
                for k, poly in enumerate(rock.polyhedra))
    return out, rock.size_distribution()


def _block_label(path: tuple) -> str:
    """How a message names a block: ``block #k`` (a [[block]]) or ``the rock mass``."""
    return f"block #{path[1] + 1}" if path[0] == "block" else "the rock mass"


def parse(ctx: _Ctx, doc: dict, overrides: dict) -> SceneSpec:
    """Check a general scene file's document (``tomllib`` output) and type it: a ``SceneSpec``.

    ``overrides``: ``dx``, ``scheme``, ``coupling`` given to ``load`` (checked as the keys they
    replace). Raises ValueError naming the file, line and key of the first refusal.
    """
    for table, value in doc.items():
        if table not in _SCHEMA or (table in _ARRAYS) != isinstance(value, list):
            if table in _SCHEMA:
                ctx.fail_table((table,), f"write it as {'[[' + table + ']]' if table in _ARRAYS else '[' + table + ']'}")
            if not isinstance(value, dict) and not isinstance(value, list):
                ctx.fail((table,), f"unknown top-level key; scene files have tables only: {', '.join(_SCHEMA)}")
            ctx.fail_table((table,), f"unknown table; accepted tables: {', '.join(_SCHEMA)}")
    scene_t = _table(ctx, ("scene",), doc.get("scene", {}), _SCHEMA["scene"])
    if scene_t["options"] is not None:
        ctx.fail(("scene", "options"), "[scene.options] are for built-in scenes; add `builtin = \"NAME\"` to [scene]")
    sph = _table(ctx, ("sph",), doc.get("sph", {}), _SCHEMA["sph"])
    cpl = _table(ctx, ("coupling",), doc.get("coupling", {}), _SCHEMA["coupling"])
    mat = _table(ctx, ("materials",), doc.get("materials", {}), _SCHEMA["materials"])
    if "dx" in overrides:
        sph["dx"] = _value(ctx, ("sph", "dx"), overrides["dx"], _SCHEMA["sph"]["dx"])
    if "scheme" in overrides:
        sph["scheme"] = _value(ctx, ("sph", "scheme"), overrides["scheme"], _SCHEMA["sph"]["scheme"])
    if "coupling" in overrides:
        cpl["method"] = _value(ctx, ("coupling", "method"), overrides["coupling"], _SCHEMA["coupling"]["method"])
    waters = _array_tables(ctx, doc, "water")
    gauges = _array_tables(ctx, doc, "gauge")
    runup = _table(ctx, ("runup",), doc["runup"], _SCHEMA["runup"]) if "runup" in doc else None
    domain = _table(ctx, ("domain",), doc["domain"], _SCHEMA["domain"]) if "domain" in doc else None
    has_water = bool(waters)
    if has_water:
        if domain is None:
            ctx.fail_table(("water", 0), "water needs a [domain] (the tank: lo, hi)")
        if sph["dx"] is None:
            ctx.fail_table(("sph",), "a scene with water needs the particle spacing: `dx = ...` (m) in [sph]")
    if domain is not None and np.any(np.asarray(domain["hi"], float) <= np.asarray(domain["lo"], float)):
        ctx.fail(("domain", "hi"), f"must exceed lo on every axis (lo {list(domain['lo'])}, hi {list(domain['hi'])})")
    fixed = _parse_fixed(ctx, doc, domain is not None)
    blocks = _parse_blocks(ctx, doc)
    rock_blocks, rock_sizes = _parse_rock_mass(ctx, doc)
    blocks += rock_blocks
    if not has_water and not any(b.motion == "dynamic" for b in blocks):
        ctx.fail_table(("scene",), "nothing moves: add [[water]] (with [domain] and [sph] dx) or a "
                                   "[[block]] with motion = \"dynamic\"")
    if gauges and not has_water:
        ctx.fail_table(("gauge", 0), "gauges measure water: add [[water]]")
    if runup is not None and not has_water:
        ctx.fail_table(("runup",), "run-up measures water: add [[water]]")
    if runup is not None and not np.linalg.norm(np.asarray(runup["normal"])) > 0:
        ctx.fail(("runup", "normal"), "must be a non-zero vector (the slope's outward normal)")
    scheme, alpha, nu = None, sph["alpha"], sph["nu"]
    if has_water:  # the scheme's terms are checked where the scene has water to run them on
        from .fluid import _scheme_defaults

        scheme, alpha, nu = _scheme_defaults(_fluid_scheme(ctx, sph), alpha, nu)
    h_factor, cfl, _ = scheme_resolution(scheme or _schemes.WCSPH(), sph["h_factor"], sph["cfl"])
    return SceneSpec(
        name=scene_t["name"] or "scene", description=scene_t["description"], still_level=scene_t["still_level"],
        domain=_fields(DomainSpec, domain) if domain is not None else None,
        waters=tuple(_fields(WaterSpec, w, path=("water", i)) for i, w in enumerate(waters)),
        fixed=fixed, blocks=blocks, materials=_fields(MaterialsSpec, mat),
        sph=_fields(SphSpec, {**sph, "scheme": scheme, "alpha": alpha, "nu": nu, "h_factor": h_factor, "cfl": cfl}),
        coupling=_fields(CouplingSpec, {**cpl, "method": Coupling(cpl["method"])}),
        gauges=tuple(_fields(GaugeSpec, g) for g in gauges),
        runup=_fields(RunupSpec, runup) if runup is not None else None, where=ctx, rock_mass=rock_sizes)


# ---- build: SceneSpec -> Scene -----------------------------------------------------------------


def _build_fixed(spec: SceneSpec, *, clip_lo, clip_hi, exact_within: float) -> list:
    """The ``[[fixed]]`` solids: ``[(FixedSolid, FixedSpec)]``."""
    from . import meshes

    ctx = spec.where
    out = []
    for f in spec.fixed:
        try:
            if f.type == "box":
                solid = meshes.fixed_box(f.lo, f.hi, name=f.name)
            elif f.type == "plane":
                solid = meshes.fixed_plane(f.point, f.normal, clip_lo=clip_lo, clip_hi=clip_hi, name=f.name)
            else:
                solid = meshes.fixed_from_mesh(f.file, scale=f.scale, offset=f.offset,
                                               convexity_tol=f.convexity_tol, name=f.name,
                                               exact_within=exact_within)
        except ValueError as exc:
            if str(exc).startswith(ctx.source):
                raise
            key = {"box": "lo", "plane": "point", "mesh": "file"}[f.type]
            ctx.fail(f.path + (key,), str(exc))
        out.append((solid, f))
    return out


def _build_blocks(spec: SceneSpec) -> list:
    """The ``[[block]]`` polyhedra placed at their centroids: ``[(ConvexPolyhedron, BlockSpec)]``."""
    from ..blocks import geometry as geo
    from .meshes import block_from_mesh

    out = []
    for b in spec.blocks:
        if b.polyhedron is not None:  # cut from the rock mass, in place
            out.append((b.polyhedron, b))
            continue
        if b.shape == "box":
            poly = geo.box(*b.size)
        elif b.shape == "wedge":
            poly = geo.wedge(*b.size)
        else:
            try:
                poly = block_from_mesh(b.file, hull=b.hull, scale=b.scale, convexity_tol=b.convexity_tol)
            except ValueError as exc:
                spec.where.fail(b.path + ("file",), str(exc))
        position = np.asarray(b.position if b.position is not None else poly.centroid_world, float)
        R = _rotation(b.rotation_axis, b.rotation_deg)
        placed = geo.ConvexPolyhedron.from_vertices(poly.vertices @ R.T + position)
        out.append((placed, b))
    return out


def _block_list(user_blocks: list, fixed: list, *, fixed_blocks) -> tuple[list, list, list, list, list]:
    """``(polyhedra, positions, motion, density, velocity)`` for ``coupled_scene``: the user's blocks,
    then the fixed solids ``fixed_blocks(solid, FixedSpec)`` selects, as FIXED blocks of 2650 kg/m^3."""
    from .. import blocks as blk

    polys, positions, motion, dens, vel = [], [], [], [], []
    for p, b in user_blocks:
        polys.append(p)
        positions.append(p.centroid_world)
        motion.append(blk.Motion.DYNAMIC if b.motion == "dynamic" else blk.Motion.FIXED)
        dens.append(b.density)
        vel.append(b.velocity)
    for s, f in fixed:
        if fixed_blocks(s, f):
            polys.append(s.polyhedron)
            positions.append(s.position)
            motion.append(blk.Motion.FIXED)
            dens.append(2650.0)
            vel.append((0.0, 0.0, 0.0))
    return polys, positions, motion, dens, vel


def _water_and_walls(spec: SceneSpec, res: Resolution, lo, hi, solids) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    """The lattice ``lo + (i + 1/2) dx`` (grown by the wall layers) as ``(points [n, 3], water mask
    [n], wall particles [m, 3], the water regions' levels [m])``: walls within ``res.wall_layers``
    dx behind the domain's faces and the fixed ``solids``, water inside a ``[[water]]`` region and
    > 0.3 dx from every wall (``build`` then clears it from the moving blocks)."""
    from .shapes import clearance, plane

    ctx, dx, layers = spec.where, res.dx, res.wall_layers
    periodic, open_top = spec.domain.periodic, spec.domain.open_top
    pad = layers * dx
    ext_lo = np.array([lo[a] if periodic[a] else lo[a] - pad for a in range(3)])
    ext_hi = np.array([hi[a] if (periodic[a] or (a == 2 and open_top)) else hi[a] + pad for a in range(3)])
    pts = lattice(ext_lo, ext_hi, dx)
    walls_hs = []
    for a in range(3):
        if periodic[a]:
            continue
        e = np.zeros(3)
        e[a] = 1.0
        walls_hs.append(plane(-e, lo))
        if not (a == 2 and open_top):
            walls_hs.append(plane(e, hi))
    phi = clearance(pts, walls_hs) if walls_hs else np.full(len(pts), np.inf)
    for s, _ in solids:
        phi = np.minimum(phi, -s.clearance(pts))
    wall_x = pts[(phi <= 0) & (phi > -layers * dx)]
    inside = np.all((pts > lo) & (pts < hi), axis=1)
    water_mask = np.zeros(len(pts), bool)
    levels = []
    for w in spec.waters:
        wlo = np.asarray(w.lo if w.lo is not None else lo)
        whi = np.asarray(w.hi if w.hi is not None else hi)
        if np.any(whi <= wlo):
            ctx.fail(w.path + ("hi",), f"must exceed lo on every axis (lo {wlo.tolist()}, hi {whi.tolist()})")
        hs = [plane(-np.eye(3)[a], wlo) for a in range(3)] + [plane(np.eye(3)[a], whi) for a in range(3)]
        if w.level is not None:
            hs.append(plane([0, 0, 1], [0, 0, w.level]))
        hs += [plane(n, p) for p, n in w.planes]
        mine = inside & (clearance(pts, hs) > 0.3 * dx) & (phi > 0.3 * dx)
        if not np.any(mine):
            ctx.fail_table(w.path, f"holds no water particle at dx = {dx:g} m (is it inside the domain and "
                                   "outside the fixed geometry?)")
        water_mask |= mine
        levels.append(w.level if w.level is not None else float(whi[2]))
    return pts, water_mask, wall_x, levels


def build(spec: SceneSpec) -> Scene:
    """The ``Scene`` of a checked scene file: water, walls and fixed geometry on one lattice, and
    the blocks (``base.fluid_scene`` without moving blocks, else ``coupled.coupled_scene``).

    Raises ValueError (file, line, key) for what only the geometry shows: a domain under 4 dx, a
    water region without particles, a moving block inside fixed geometry, a mesh that fails.
    """
    from .coupled import coupled_scene, coupling_params
    from .meshes import fixed_from_polyhedron, world_halfspaces
    from .shapes import clearance

    ctx, sph, cpl, mat = spec.where, spec.sph, spec.coupling, spec.materials
    has_water = bool(spec.waters)
    dx = sph.dx
    res = Resolution(dx, sph.h_factor) if has_water else None
    layers = res.wall_layers if has_water else 0

    # ---- domain and lattice -------------------------------------------------------------------
    if spec.domain is not None:
        lo = np.asarray(spec.domain.lo, float)
        hi = np.asarray(spec.domain.hi, float)
        if has_water:
            n = np.round((hi - lo) / dx).astype(int)
            if np.any(n < 4):
                ctx.fail(("domain", "hi"), f"the domain must be at least 4 dx = {4 * dx:g} m on every axis "
                                           f"(sizes {(hi - lo).tolist()} m); enlarge it or use a smaller dx")
            hi = lo + n * dx  # whole cells
            try:
                check_lattice_size(np.prod(n + 2 * (layers + 1)), dx, "this domain")
            except ValueError as exc:
                ctx.fail(("sph", "dx"), str(exc))
        grow = (layers + 1) * dx if has_water else 0.1 * float(np.max(hi - lo))
        clip_lo, clip_hi = lo - grow, hi + grow
    else:
        clip_lo = clip_hi = None
    fixed = _build_fixed(spec, clip_lo=clip_lo, clip_hi=clip_hi, exact_within=(layers + 1) * dx if has_water else 0.0)
    user_blocks = _build_blocks(spec)
    moving = [(p, b) for p, b in user_blocks if b.motion == "dynamic"]

    # fixed user blocks are fixed geometry for the water too
    solids = [(s, f.path) for s, f in fixed]
    solids += [(fixed_from_polyhedron(p, p.centroid_world, name=_block_label(b.path) if b.path[0] == "block" else b.name), b.path)
               for p, b in user_blocks if b.motion == "fixed"]

    # moving blocks must not start inside fixed geometry
    for poly, b in moving:
        verts = poly.vertices + poly.centroid_world
        size = 2 * poly.bounding_radius
        for s, spath in solids:
            depth = float(np.max(s.clearance(verts)))
            if depth > 1e-3 * size:
                ctx.fail(b.path + ("position",), f"the block starts {depth:.3g} m inside {s.name} "
                                                 f"(line {ctx.lines.line(spath)}); move it out")

    # nor inside each other (the check make_blocks makes, at the scene file's tolerance)
    from ..blocks.model import initial_overlaps

    polys = [p for p, _ in moving]
    for i, j, depth in initial_overlaps(polys, [p.centroid_world for p in polys]):
        if depth > 1e-3 * 2 * min(polys[i].bounding_radius, polys[j].bounding_radius):
            bi, bj = moving[i][1], moving[j][1]
            ctx.fail(bj.path + ("position",), f"the block starts {depth:.3g} m inside {_block_label(bi.path)} "
                                              f"(line {ctx.lines.line(bi.path)}); move them apart")

    meta: dict[str, Any] = {"description": spec.description} if spec.description else {}
    if spec.rock_mass is not None:
        meta["rock_mass"] = spec.rock_mass
    block_kwargs = mat.block_kwargs()
    if any(b.locked for _, b in user_blocks):  # guided blocks: one spec per block, the fixed solids after them
        n_fixed = sum(1 for s, f in fixed if s.polyhedron is not None and (f.block or not has_water))
        block_kwargs = {**block_kwargs, "locked": [b.locked or None for _, b in user_blocks] + [None] * n_fixed}
    if not has_water:  # blocks only
        for s, f in fixed:
            if s.polyhedron is None:
                ctx.fail_table(f.path, "a non-convex fixed mesh cannot be a block (blocks-only scene); split it into "
                                       "convex pieces")
        polys, positions, motion, dens, vel = _block_list(user_blocks, fixed, fixed_blocks=lambda s, f: True)
        try:
            return coupled_scene(name=spec.name, dx=None, polyhedra=polys, positions=positions,
                                 motion=motion, block_density=dens, friction_angle_deg=mat.friction_angle_deg,
                                 velocities=vel, block_kwargs=block_kwargs, meta=meta)
        except ValueError as exc:
            raise ValueError(f"{ctx.source}: building the blocks failed: {exc}") from exc

    # ---- particles ----------------------------------------------------------------------------
    pts, water_mask, wall_x, levels = _water_and_walls(spec, res, lo, hi, solids)
    for poly, _ in moving:
        phib = clearance(pts, world_halfspaces(poly, poly.centroid_world))
        water_mask &= phib < -0.25 * dx
    fluid_x = pts[water_mask]
    if len(fluid_x) == 0:
        ctx.fail_table(("water", 0), "no water particle is left outside the blocks")
    still = spec.still_level if spec.still_level is not None else max(levels)
    z_bottom = float(np.min(fluid_x[:, 2])) - 0.5 * dx
    speed = math.sqrt(2 * GRAVITY * max(still - z_bottom, dx))
    for poly, b in moving:
        drop = max(float(poly.centroid_world[2]) - z_bottom, 0.0)
        speed = max(speed, float(np.linalg.norm(b.velocity)) + math.sqrt(2 * GRAVITY * drop))
    c0 = sph.c0 if sph.c0 is not None else 10.0 * speed
    periodic = spec.domain.periodic
    pad = layers * dx
    dom_lo = np.array([lo[a] if periodic[a] else lo[a] - pad for a in range(3)])
    dom_hi = np.array([hi[a] if periodic[a] else hi[a] + pad for a in range(3)])
    meta.update(still_level=float(still), domain_lo=lo.tolist(), domain_hi=hi.tolist(), c0=float(c0))
    if spec.gauges:
        meta["gauges"] = dict(names=[g.name or f"g{i + 1}" for i, g in enumerate(spec.gauges)],
                              xy=[list(g.xy) for g in spec.gauges],
                              bottom_z=[g.bottom_z if g.bottom_z is not None else float(lo[2]) for g in spec.gauges])
    if spec.runup is not None:
        n = np.asarray(spec.runup.normal)
        meta["runup_slope"] = dict(point=list(spec.runup.point), normal=(n / np.linalg.norm(n)).tolist(),
                                   x_min=spec.runup.x_min)
    walls_only = [s.name for s, f in fixed if s.polyhedron is None or not f.block]
    if walls_only:
        meta["fixed_walls_only"] = walls_only
    common = dict(h_factor=sph.h_factor, alpha=sph.alpha, nu=sph.nu, delta=sph.delta,
                  wall_viscosity=sph.wall_viscosity,
                  # the builders' defaults: the scheme's for water only, 0.6 dx with moving blocks
                  skin_factor=sph.skin_factor if sph.skin_factor is not None else (
                      0.6 if moving else sph.scheme.default_skin_factor),
                  rebuild_every=sph.rebuild_every, cfl=sph.cfl)
    if not moving:
        return fluid_scene(name=spec.name, dx=dx, fluid_x=fluid_x, wall_x=wall_x, domain_lo=dom_lo,
                           domain_hi=dom_hi, periodic=tuple(periodic), surface_z=still, c0=c0, scheme=sph.scheme,
                           meta=meta, **common)
    if walls_only and any(s.polyhedron is None for s, _ in fixed):
        warnings.warn(f"{ctx.source}: {', '.join(walls_only)} is not convex: it is walls for the water only, and "
                      "moving blocks will pass through it (split it into convex pieces to make it a block)",
                      stacklevel=4)
    polys, positions, motion, dens, vel = _block_list(
        user_blocks, fixed, fixed_blocks=lambda s, f: s.polyhedron is not None and f.block)
    try:
        scene = coupled_scene(name=spec.name, dx=dx, polyhedra=polys, positions=positions,
                              motion=motion, block_density=dens, friction_angle_deg=mat.friction_angle_deg,
                              fluid_x=fluid_x, wall_x=wall_x, domain_lo=dom_lo, domain_hi=dom_hi,
                              periodic=tuple(periodic), still_level=still, coupling=cpl.method, c0=c0,
                              scheme=sph.scheme, velocities=vel, joint_water=mat.joint_water, coupling_guard=cpl.guard,
                              guard_fixed=cpl.guard_fixed,
                              block_kwargs=block_kwargs,
                              meta=meta, **common)
    except ValueError as exc:
        raise ValueError(f"{ctx.source}: building the scene failed: {exc}") from exc
    if scene.params.coupling is not None and any(v is not None for v in (cpl.stiffness, cpl.damping,
                                                                          cpl.interaction_distance)):
        scene = scene.replace(params=scene.params.replace(coupling=coupling_params(
            dx=dx, c0=c0, stiffness=cpl.stiffness, damping=cpl.damping,
            interaction_distance=cpl.interaction_distance, coupling=cpl.method)))
    return scene


def _load_general(ctx: _Ctx, doc: dict, overrides: dict) -> Scene:
    return build(parse(ctx, doc, overrides))


#: scene-file keys of ``[sph]`` -> the scheme's term slots (``sph.schemes.from_names``)
_TERM_KEYS = {"kernel": "kernel", "viscosity": "viscosity", "wall_model": "walls", "density_diffusion": "diffusion",
              "shifting": "shifting", "seed_gradient": "gradient"}


def _fluid_scheme(ctx, sph: dict):
    """The fluid scheme object of an ``[sph]`` table: the scheme by name with the terms whose keys
    are given (a term that does not apply to the scheme is refused, naming its key)."""
    terms = {slot: sph[key] for key, slot in _TERM_KEYS.items() if sph[key] is not None}
    for key, slot in _TERM_KEYS.items():
        if slot in terms:
            try:
                _schemes.from_names(sph["scheme"], **{slot: terms[slot]})
            except ValueError:
                ctx.fail(("sph", key), f'does not apply to scheme = "{sph["scheme"]}"; remove the key or change the scheme')
    return _schemes.from_names(sph["scheme"], **terms)
