"""Can this gradient be trusted at the scale a calibration moves? A diagnostic for users.

This module owns :func:`gradcheck` and its report. For a scalar ``loss(params)`` and chosen
scalar leaves (paths as in ``rockjax.calibrate.get_leaf``: ``"blocks.density[0]"``,
``"blocks.friction_angle"``, ``"fluid.c0"``) it computes

* the gradient by automatic differentiation (``jax.value_and_grad``, one call);
* central secants ``(L(x + h) - L(x - h)) / 2h`` at several relative steps ``h = r |x|``
  (default ``r`` = 1e-2 ... 1e-6);
* optionally a 1-D scan of the loss over ``x (1 + s)``, ``s`` in ``[-scan_width, scan_width]``
  (:meth:`GradCheckReport.plot` draws it with the secants' lines and the AD tangent, PNG).

and classifies each leaf (:attr:`LeafCheck.verdict`):

* ``"ok"``: the secants at the two calibration-scale steps (``calibration_steps``, default 1e-3
  and 1e-4) agree with each other and with AD within ``rtol``: the gradient describes the loss
  over the distance an optimiser moves;
* ``"rough"``: the calibration-scale secants disagree with each other, or agree with each other
  but not with AD while the smallest steps do agree with AD: the derivative is exact but local
  (kinks or jumps of the loss lie closer than the calibration step: contact or stick-slip events,
  chaotic dynamics). Smooth the model (``blocks.laws.SmoothPenaltyCoulomb``, the coupling's
  ``onset``) or the objective (``rockjax.ensembles.smoothed_value_and_grad``);
* ``"wrong"``: the secants converge (two successive steps agree within ``rtol``) to a value AD
  does not match: a gradient bug (please report it);
* ``"unresolved"``: no two successive secants agree (round-off dominates the small steps and
  roughness the large ones), so nothing can be said; in float32 this is the usual outcome, hence
  run it with ``jax.config.update("jax_enable_x64", True)``.

Each loss evaluation is one forward run: a check of k leaves at s steps costs ``2 k s`` forwards
plus one gradient, and the scan ``scan_points`` forwards per leaf. ``loss`` is jitted once here
(pass an already jitted one to share its compile).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .calibrate import get_leaf, set_leaf

__all__ = ["gradcheck", "classify", "GradCheckReport", "LeafCheck", "VERDICTS"]

#: the verdicts of :attr:`LeafCheck.verdict`, from best to worst
VERDICTS = ("ok", "rough", "wrong", "unresolved")


def _rel(a: float, b: float) -> float:
    """|a - b| relative to the larger magnitude (0 when both are 0)."""
    s = max(abs(a), abs(b))
    return 0.0 if s == 0.0 else abs(a - b) / s


@dataclasses.dataclass(frozen=True)
class LeafCheck:
    """The check of one scalar leaf (see the module docstring for the verdicts)."""

    path: str
    value: float  #: the leaf's value at the checked point
    ad: float  #: d loss / d leaf by automatic differentiation
    steps: tuple  #: relative steps r of the secants (absolute step r |value|), largest first
    fd: tuple  #: the central secants at ``steps``
    calibration_steps: tuple  #: the two steps that decide "ok"
    rtol: float
    verdict: str
    scan: Optional[tuple] = None  #: (relative offsets s [n], loss values [n]) or None

    def fd_at(self, r: float) -> float:
        """The secant at relative step ``r`` (one of ``steps``)."""
        return self.fd[self.steps.index(r)]

    @property
    def converged_fd(self) -> Optional[float]:
        """The secant of the largest step that agrees (``rtol``) with the next smaller step, or None."""
        for a, b in zip(self.fd[:-1], self.fd[1:]):
            if _rel(a, b) <= self.rtol:
                return b
        return None

    def row(self) -> str:
        fds = "  ".join(f"{r:.0e}:{v:+.4e}" for r, v in zip(self.steps, self.fd))
        return f"{self.path:28s} {self.verdict:10s} AD {self.ad:+.6e}  FD {fds}"


@dataclasses.dataclass(frozen=True)
class GradCheckReport:
    """What :func:`gradcheck` found: the loss at the point, one :class:`LeafCheck` per leaf."""

    loss: float
    leaves: tuple
    x64: bool  #: whether the check ran in float64

    @property
    def ok(self) -> bool:
        """Every leaf's verdict is "ok"."""
        return all(c.verdict == "ok" for c in self.leaves)

    def __getitem__(self, path: str) -> LeafCheck:
        for c in self.leaves:
            if c.path == path:
                return c
        raise KeyError(path)

    def __str__(self) -> str:
        head = f"gradcheck: loss {self.loss:.8e} ({'float64' if self.x64 else 'float32: secants are unreliable'})"
        return "\n".join([head] + [c.row() for c in self.leaves])

    def plot(self, path) -> str:
        """A PNG of every leaf's scan (loss vs relative offset), with the AD tangent and the
        secants' chords; returns the file name. Needs matplotlib and ``scan_points`` > 0."""
        from .plots import _figure

        checks = [c for c in self.leaves if c.scan is not None]
        if not checks:
            raise ValueError("GradCheckReport.plot: no leaf was scanned; call gradcheck(..., scan_points=21)")
        fig, axes = _figure(len(checks), 1, size=(7.0, 3.2 * len(checks)))
        for ax, c in zip(axes[:, 0], checks):
            s, L = c.scan
            ax.plot(s, L, "k.-", lw=0.8, ms=3, label="loss")
            dx = s * c.value
            ax.plot(s, self.loss + c.ad * dx, "C0-", lw=1.0, label="AD tangent")
            for k, (r, g) in enumerate(zip(c.steps, c.fd)):
                if r <= float(np.max(np.abs(s))) + 1e-300:
                    ax.plot(s, self.loss + g * dx, f"C{k + 1}--", lw=0.8, label=f"secant r={r:.0e}")
            ax.set_title(f"{c.path} = {c.value:.6g}: {c.verdict}")
            ax.set_xlabel("relative offset of the leaf")
            ax.set_ylabel("loss")
            ax.legend(fontsize=7)
        fig.savefig(path)
        return str(path)


def classify(ad: float, steps: Sequence[float], fd: Sequence[float], calibration_steps=(1e-3, 1e-4),
             rtol: float = 0.02) -> str:
    """The verdict (module docstring) on one derivative from its AD value and its central
    secants ``fd`` at relative ``steps`` (largest first), for callers that computed them
    themselves (e.g. secants of a whole observation record from one pair of runs)."""
    steps, fd = list(steps), list(fd)
    if steps != sorted(steps, reverse=True):
        raise ValueError(f"classify: steps must be sorted largest first (got {steps})")
    return _verdict(float(ad), steps, [float(x) for x in fd], tuple(calibration_steps), rtol)


def _verdict(ad: float, steps, fd, cal, rtol: float) -> str:
    a, b = (fd[steps.index(r)] for r in cal)
    if _rel(a, b) <= rtol and _rel(a, ad) <= rtol and _rel(b, ad) <= rtol:
        return "ok"
    pairs = list(zip(fd[:-1], fd[1:]))
    # the finest converged pair (two successive secants that agree): the local derivative
    local = [y for x, y in pairs if _rel(x, y) <= rtol]
    if not local:
        return "unresolved"
    if _rel(local[-1], ad) <= rtol:
        return "rough"
    return "wrong"


def gradcheck(loss: Callable, params, leaves: Sequence[str], *,
              steps: Sequence[float] = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6),
              calibration_steps: Sequence[float] = (1e-3, 1e-4), rtol: float = 0.02,
              scan_points: int = 0, scan_width: float = 1e-2, abs_step: float = 1e-4,
              jit: bool = True, value_and_grad: Optional[Callable] = None) -> GradCheckReport:
    """Compare ``jax.grad(loss)`` with central secants at several steps, leaf by leaf.

    Args:
      loss: ``loss(params) -> []`` (e.g. ``calibrate.make_loss(...)``), differentiable.
      params: the point to check (a ``Params`` or any pytree of dataclasses ``get_leaf`` reads).
      leaves: paths of scalar leaves, e.g. ``["blocks.density[0]", "blocks.friction_angle"]``.
      steps: relative secant steps r (absolute ``r |value|``; ``abs_step`` where the value is 0),
        sorted largest first here; must include ``calibration_steps``.
      calibration_steps: two steps of the size a calibration moves; "ok" needs their secants and
        AD to agree within ``rtol``.
      rtol: relative agreement (default 2 %).
      scan_points: if > 0, evaluate the loss at that many offsets ``s`` evenly over
        ``[-scan_width, scan_width]`` (relative) for :meth:`GradCheckReport.plot`.
      jit: jit ``loss`` (and its gradient) here; pass ``jit=False`` with an already jitted ``loss``
        and ``value_and_grad`` to share their compiles between checks.
      value_and_grad: ``params -> (loss, grads)``; default ``jax.value_and_grad(loss)``.
    Returns:
      :class:`GradCheckReport` (``print`` it; ``report.ok``; ``report["blocks.density[0]"]``).
    Raises:
      ValueError: empty ``leaves``, a non-scalar leaf, ``calibration_steps`` not among ``steps``,
        non-positive steps, or a non-finite loss or gradient at the point.
    """
    if not leaves:
        raise ValueError("gradcheck: leaves is empty; name at least one scalar leaf, e.g. 'blocks.density[0]'")
    steps = tuple(sorted((float(r) for r in steps), reverse=True))
    cal = tuple(float(r) for r in calibration_steps)
    if any(r <= 0 for r in steps) or len(set(steps)) != len(steps):
        raise ValueError(f"gradcheck: steps must be distinct and positive (got {steps})")
    if len(cal) != 2 or any(r not in steps for r in cal):
        raise ValueError(f"gradcheck: calibration_steps must be two of steps {steps} (got {cal})")
    if not rtol > 0:
        raise ValueError(f"gradcheck: rtol must be positive (got {rtol})")
    for p in leaves:
        if np.ndim(get_leaf(params, p)) != 0:
            raise ValueError(f"gradcheck: leaf {p!r} has shape {np.shape(get_leaf(params, p))}; "
                             "name one entry, e.g. 'blocks.density[0]'")
    f = jax.jit(loss) if jit else loss
    if value_and_grad is not None:
        vg = value_and_grad
    else:
        vg = jax.jit(jax.value_and_grad(loss)) if jit else jax.value_and_grad(loss)
    L0, g = vg(params)
    x64 = jnp.asarray(L0).dtype == jnp.float64
    L0 = float(L0)
    if not math.isfinite(L0):
        raise ValueError(f"gradcheck: the loss is not finite at the point ({L0})")
    out = []
    for p in leaves:
        ad = float(get_leaf(g, p))
        if not math.isfinite(ad):
            raise ValueError(f"gradcheck: the AD derivative w.r.t. {p!r} is not finite ({ad})")
        x0 = float(get_leaf(params, p))
        scale = abs(x0) if x0 != 0.0 else abs_step
        fd = []
        for r in steps:
            h = r * scale
            fd.append((float(f(set_leaf(params, p, x0 + h))) - float(f(set_leaf(params, p, x0 - h)))) / (2 * h))
        scan = None
        if scan_points > 0:
            s = np.linspace(-scan_width, scan_width, int(scan_points))
            vals = np.array([float(f(set_leaf(params, p, x0 + si * scale))) for si in s])
            scan = (s, vals)
        out.append(LeafCheck(p, x0, ad, steps, tuple(fd), cal, float(rtol), _verdict(ad, steps, fd, cal, rtol), scan))
    return GradCheckReport(L0, tuple(out), bool(x64))
