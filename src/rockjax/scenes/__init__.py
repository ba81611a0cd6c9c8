"""Built-in scenes. Each builder takes keyword-only arguments in SI units (resolution ``dx``)
and returns a ``Scene``; ``BUILTIN`` maps CLI names to builders; ``load_scene`` / ``load_file``
read a scene described in a TOML file (``rockjax.scenes.scenefile``); ``settle`` relaxes a scene's
water before its run."""

from .base import Resolution, Scene, check_param_values, check_params, stable_dt
from .coupled import block_drop, block_on_incline, floating_box, piston_wavemaker, rock_slope, sliding_wedge, wave_flume
from .fjord import fjord, fjord_estimate
from .fluid import dam_break, hydrostatic_tank, wave_box
from .meta import Gauges, RunupSlope, SceneMeta
from .scenefile import load as load_file, load_scene
from .settle import settle

BUILTIN = {
    "sliding_wedge": sliding_wedge,
    "rock_slope": rock_slope,
    "dam_break": dam_break,
    "hydrostatic_tank": hydrostatic_tank,
    "wave_box": wave_box,
    "piston_wavemaker": piston_wavemaker,
    "wave_flume": wave_flume,
    "floating_box": floating_box,
    "block_drop": block_drop,
    "block_on_incline": block_on_incline,
    "fjord": fjord,
}

#: built-in scenes too large to build for a dry run: their cost from the geometry (``rockjax run NAME --dry-run``)
ESTIMATES = {"fjord": fjord_estimate}

__all__ = ["Scene", "SceneMeta", "Gauges", "RunupSlope", "Resolution", "BUILTIN", "ESTIMATES", "dam_break", "hydrostatic_tank", "wave_box", "sliding_wedge", "rock_slope", "piston_wavemaker", "wave_flume",
           "floating_box", "block_drop", "block_on_incline", "fjord", "fjord_estimate", "check_params", "check_param_values", "stable_dt", "load_scene", "load_file", "settle"]
