"""The hook through which an implicit scheme's sweeps stay consistent over a decomposed scene.

An explicit step reads its neighbours' state once, which the decomposition's per-step halo copy
provides (``rockjax.decomposition``). An implicit solve (``DFSPH``) updates per-particle values
(pressures, velocities) in sweeps, each read by the neighbours in the next one, and stops on a
mean residual over all the water: on a decomposed scene every sweep must refresh the halo copies,
and the mean must be taken over all devices (so that every device runs the same sweeps).

The decomposition sets the current ``Exchange`` while it traces the step
(``with exchanging(comm): ...``: a trace-time scope, like a ``jax.named_scope``); a scheme calls
``sync`` and ``total`` at the points where it needs them, and outside a decomposed trace they
return their argument unchanged (nothing is added to the program).
"""

from __future__ import annotations

import contextlib
from typing import Optional, Protocol

__all__ = ["Exchange", "exchanging", "sync", "total", "owned"]


class Exchange(Protocol):
    """What a decomposition provides while it traces a step."""

    def sync(self, values):
        """``values`` [N, ...] (or [n_fluid, ...]) with the fluid segment's halo rows replaced by
        their owners' current values."""

    def total(self, value):
        """``value`` summed over the devices."""

    def owned(self, n: int):
        """[n] bool: the first ``n`` local rows this device owns."""


_current: Optional[Exchange] = None


@contextlib.contextmanager
def exchanging(comm: Exchange):
    """Trace the enclosed code with ``comm`` as the current exchange."""
    global _current
    previous, _current = _current, comm
    try:
        yield comm
    finally:
        _current = previous


def sync(values):
    """The halo rows of ``values`` refreshed from their owners (unchanged outside a decomposed trace)."""
    return values if _current is None else _current.sync(values)


def total(value):
    """``value`` summed over the devices (unchanged outside a decomposed trace)."""
    return value if _current is None else _current.total(value)


def owned(mask):
    """``mask`` [n] restricted to the rows this device owns (unchanged outside a decomposed trace)."""
    return mask if _current is None else mask & _current.owned(mask.shape[0])
