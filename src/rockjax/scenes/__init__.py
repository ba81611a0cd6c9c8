"""Built-in scenes. Each builder takes keyword-only arguments in SI units (resolution ``dx``)
and returns a ``Scene``; ``BUILTIN`` maps CLI names to builders."""

from .base import Scene, check_params, stable_dt
from .fluid import dam_break, hydrostatic_tank

BUILTIN = {
    "dam_break": dam_break,
    "hydrostatic_tank": hydrostatic_tank,
}

__all__ = ["Scene", "BUILTIN", "dam_break", "hydrostatic_tank", "check_params", "stable_dt"]
