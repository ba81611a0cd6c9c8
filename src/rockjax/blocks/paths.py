"""Prescribed paths of PRESCRIBED blocks: wave-maker paddles of any motion, slides on a given path.

This module owns the ``Path`` interface and its kinds, the wave-maker signal generators and the
linear wave-maker theory they use:

* paths (static, hashable; a ``BlockConfig.paths`` entry per PRESCRIBED block):
  :class:`Table` -- a translation ``x0 + u(t)`` from a table ``(t, u)`` (1D along a direction or
  3D), and :class:`Flap` -- a rotation by ``theta(t)`` about a hinge line (a flap paddle). Both
  interpolate their table with a clamped cubic spline (C2 inside, zero velocity at both ends, held
  still before and after: the velocity is continuous everywhere, the acceleration bounded).
  The block's velocity is the spline's exact derivative, so positions and velocities agree.
* signals (:class:`PaddleSignal`: the paddle's displacement at the still water level, m, against
  time) from generators: :func:`regular` (a ramped sine, given the wave height or the stroke),
  :func:`solitary` (Goring 1978), :func:`focused_group` (linear components focusing at a place and
  time), :func:`jonswap` (an irregular sea from a JONSWAP spectrum, seeded), :func:`read_csv` (a
  measured paddle record); a signal becomes a path with :meth:`PaddleSignal.piston` or
  :meth:`PaddleSignal.flap`.
* linear theory: :func:`wavenumber` (the dispersion relation), :func:`piston_transfer` and
  :func:`flap_transfer` (Biesel's H/S), :func:`jonswap_spectrum`.

Differentiable scale: every path's displacement (or angle) is multiplied by
``params.stroke / BlockConfig.path_stroke`` (1 as built: ``path_stroke`` is the stroke the scene
was built with), so ``jax.grad`` w.r.t. ``BlockParams.stroke`` is the gradient w.r.t. a scaling
of the paddle motion. The sinusoidal piston of ``BlockConfig.prescribed_direction`` (no
``paths``) keeps its own formula (``integrate.prescribed_motion``).

Units: SI (m, s, rad); tables are host numpy arrays, evaluated in jit with ``searchsorted`` (the
time carries no gradient).
"""

from __future__ import annotations

import abc
import dataclasses
import hashlib
import math

import jax.numpy as jnp
import numpy as np

__all__ = ["Path", "Table", "Flap", "PaddleSignal", "regular", "solitary", "focused_group", "jonswap",
           "read_csv", "wavenumber", "piston_transfer", "flap_transfer", "jonswap_spectrum", "GRAVITY"]

GRAVITY = 9.81


# ---------------------------------------------------------------------------------------------
# the clamped cubic spline (host coefficients, jit evaluation)


def _spline(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Coefficients [N-1, 4, D] (c0 + c1 s + c2 s^2 + c3 s^3, s = t - t_i) of the clamped cubic
    spline through ``values`` [N, D] at increasing ``times`` [N] (zero slope at both ends)."""
    from scipy.interpolate import CubicSpline

    cs = CubicSpline(times, values, axis=0, bc_type="clamped")
    c = np.asarray(cs.c)  # [4, N-1, D], highest power first
    return np.ascontiguousarray(np.transpose(c[::-1], (1, 0, 2)))


def _evaluate(times: np.ndarray, coef: np.ndarray, t, dtype):
    """Value and derivative [D] of the spline at t (held at the end values outside the table, with
    zero derivative there)."""
    knots = jnp.asarray(times, dtype)
    c = jnp.asarray(coef, dtype)
    tc = jnp.clip(t, knots[0], knots[-1])
    i = jnp.clip(jnp.searchsorted(knots, tc, side="right") - 1, 0, knots.shape[0] - 2)
    s = tc - knots[i]
    ci = c[i]
    value = ci[0] + s * (ci[1] + s * (ci[2] + s * ci[3]))
    rate = ci[1] + s * (2.0 * ci[2] + 3.0 * s * ci[3])
    inside = (t >= knots[0]) & (t <= knots[-1])
    return value, jnp.where(inside, rate, 0.0)


def _check_table(owner: str, times, values, ndim_values: int | tuple):
    times = np.asarray(times, np.float64)
    values = np.asarray(values, np.float64)
    if times.ndim != 1 or times.size < 2:
        raise ValueError(f"{owner}.times must be a 1D array of at least 2 times (got shape {times.shape})")
    if not np.all(np.isfinite(times)) or not np.all(np.diff(times) > 0):
        raise ValueError(f"{owner}.times must be finite and strictly increasing")
    if values.shape[0] != times.size:
        raise ValueError(f"{owner}: {values.shape[0]} values for {times.size} times: give one per time")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{owner}: the table holds a non-finite value (NaN or inf)")
    return times, values


def _digest(*arrays) -> str:
    h = hashlib.sha1()
    for a in arrays:
        a = np.ascontiguousarray(np.asarray(a, np.float64))
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


class Path(abc.ABC):
    """The motion of one PRESCRIBED block (a static object: hashable, compared by value).

    ``motion(t, x0, q0, scale)`` returns the pose and its rate at time t (s): ``(x [3] m, q [4]
    (w,x,y,z), v [3] m/s, omega [3] rad/s)`` of a block whose rest pose is ``(x0, q0)``; ``scale``
    multiplies the motion (``params.stroke / BlockConfig.path_stroke``). ``stroke`` (m) is the
    paddle's stroke at the still water level as tabulated (what ``scale = 1`` means), ``end`` (s)
    the time the motion stops.
    """

    stroke: float
    end: float

    @abc.abstractmethod
    def motion(self, t, x0, q0, scale):
        ...

    def __hash__(self):
        return hash((type(self).__name__, self._key()))

    def __eq__(self, other):
        return type(self) is type(other) and self._key() == other._key()

    @abc.abstractmethod
    def _key(self) -> tuple:
        ...


@dataclasses.dataclass(frozen=True, eq=False)
class Table(Path):
    """A translation from a table: ``x(t) = x0 + scale u(t)``, orientation fixed.

    Attributes:
      times: [N] s, strictly increasing (before ``times[0]`` the block rests at ``x0 + u[0]``,
        after ``times[-1]`` at ``x0 + u[-1]``).
      displacement: [N] m along ``direction``, or [N, 3] m world-frame offsets.
      direction: unit 3-vector for a 1D table (normalised here; default +x).
      stroke: m, the table's stroke (default: the peak-to-peak displacement, along ``direction``
        for a 1D table, else the largest component's).
    """

    times: np.ndarray
    displacement: np.ndarray
    direction: tuple = (1.0, 0.0, 0.0)
    stroke: float = None  # type: ignore[assignment]

    def __post_init__(self):
        times, u = _check_table("Table", self.times, self.displacement, (1, 2))
        d = np.asarray(self.direction, np.float64)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
            raise ValueError(f"Table.direction must be a finite non-zero 3-vector (got {self.direction})")
        d = d / np.linalg.norm(d)
        if u.ndim == 1:
            stroke = float(np.ptp(u))
            u3 = u[:, None] * d
        elif u.ndim == 2 and u.shape[1] == 3:
            stroke = float(np.max(np.ptp(u, axis=0)))
            u3 = u
        else:
            raise ValueError(f"Table.displacement must be [N] (along direction) or [N, 3] (got {u.shape})")
        if self.stroke is not None:
            stroke = float(self.stroke)
        if not (math.isfinite(stroke) and stroke > 0):
            raise ValueError(f"Table.stroke must be > 0 m (a table that does not move has none; got {stroke})")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "displacement", u)
        object.__setattr__(self, "direction", tuple(float(c) for c in d))
        object.__setattr__(self, "stroke", stroke)
        object.__setattr__(self, "_coef", _spline(times, u3))

    @property
    def end(self) -> float:
        return float(self.times[-1])

    def _key(self):
        return (_digest(self.times, self.displacement), self.direction, self.stroke)

    def motion(self, t, x0, q0, scale):
        u, du = _evaluate(self.times, self._coef, t, x0.dtype)
        return x0 + scale * u, q0, scale * du, jnp.zeros_like(x0)


@dataclasses.dataclass(frozen=True, eq=False)
class Flap(Path):
    """A rotation about a hinge line by ``scale * theta(t)``: a flap paddle.

    ``x(t) = hinge + R(theta) (x0 - hinge)``, ``q(t) = q_axis(theta) q0``, ``omega = theta' axis``,
    ``v = omega x (x - hinge)``; theta > 0 turns right-handed about ``axis`` (for a paddle facing
    +x with its hinge below, ``axis = (0, 1, 0)`` tips its top towards +x).

    Attributes:
      times: [N] s, strictly increasing.  angles: [N] rad.
      hinge: [3] m, a point of the hinge line.  axis: its direction (normalised here).
      lever: m, height of the still water level above the hinge (the stroke is measured there).
      stroke: m, the table's stroke at the still water level, ``lever * ptp(tan theta)`` by default.
    """

    times: np.ndarray
    angles: np.ndarray
    hinge: tuple
    axis: tuple = (0.0, 1.0, 0.0)
    lever: float = 1.0
    stroke: float = None  # type: ignore[assignment]

    def __post_init__(self):
        times, a = _check_table("Flap", self.times, self.angles, 1)
        if a.ndim != 1 or np.max(np.abs(a)) >= 0.5 * math.pi:
            raise ValueError("Flap.angles must be [N] radians below pi/2 in magnitude")
        h = np.asarray(self.hinge, np.float64)
        ax = np.asarray(self.axis, np.float64)
        if h.shape != (3,) or not np.all(np.isfinite(h)):
            raise ValueError(f"Flap.hinge must be a finite 3-vector (got {self.hinge})")
        if ax.shape != (3,) or not np.all(np.isfinite(ax)) or np.linalg.norm(ax) == 0:
            raise ValueError(f"Flap.axis must be a finite non-zero 3-vector (got {self.axis})")
        if not (math.isfinite(self.lever) and self.lever > 0):
            raise ValueError(f"Flap.lever must be > 0 m, the still water level's height above the hinge "
                             f"(got {self.lever})")
        stroke = float(self.lever * np.ptp(np.tan(a))) if self.stroke is None else float(self.stroke)
        if not (math.isfinite(stroke) and stroke > 0):
            raise ValueError(f"Flap.stroke must be > 0 m (got {stroke})")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "angles", a)
        object.__setattr__(self, "hinge", tuple(float(c) for c in h))
        object.__setattr__(self, "axis", tuple(float(c) for c in ax / np.linalg.norm(ax)))
        object.__setattr__(self, "stroke", stroke)
        object.__setattr__(self, "_coef", _spline(times, a[:, None]))

    @property
    def end(self) -> float:
        return float(self.times[-1])

    def _key(self):
        return (_digest(self.times, self.angles), self.hinge, self.axis, self.lever, self.stroke)

    def motion(self, t, x0, q0, scale):
        from .rotation import quat_matrix, quat_mul

        f = x0.dtype
        th, dth = _evaluate(self.times, self._coef, t, f)
        th, dth = scale * th[0], scale * dth[0]
        n = jnp.asarray(self.axis, f)
        hinge = jnp.asarray(self.hinge, f)
        qa = jnp.concatenate([jnp.cos(0.5 * th)[None], jnp.sin(0.5 * th) * n])
        x = hinge + quat_matrix(qa) @ (x0 - hinge)
        omega = dth * n
        return x, quat_mul(qa, q0), jnp.cross(omega, x - hinge), omega


# ---------------------------------------------------------------------------------------------
# linear wave-maker theory


def wavenumber(omega, depth: float, g: float = GRAVITY):
    """k [rad/m] of linear waves of angular frequency ``omega`` [rad/s] (scalar or array) in water
    of ``depth`` [m]: the root of ``omega^2 = g k tanh(k h)`` (Newton from Eckart's estimate)."""
    w = np.asarray(omega, np.float64)
    k = w * w / g / np.sqrt(np.tanh(w * w * depth / g))
    for _ in range(50):
        th = np.tanh(k * depth)
        f = g * k * th - w * w
        df = g * th + g * k * depth * (1.0 - th * th)
        k = k - f / df
    return k


def piston_transfer(kh):
    """Biesel's piston H/S = 2 (cosh 2kh - 1) / (sinh 2kh + 2kh) (linear theory, far field)."""
    kh = np.asarray(kh, np.float64)
    return 2.0 * (np.cosh(2 * kh) - 1.0) / (np.sinh(2 * kh) + 2 * kh)


def flap_transfer(kh):
    """Biesel's flap (hinged at the bed) H/S = 4 (sinh kh / kh) (kh sinh kh - cosh kh + 1) /
    (sinh 2kh + 2kh), S the stroke at the still water level."""
    kh = np.asarray(kh, np.float64)
    return 4.0 * (np.sinh(kh) / kh) * (kh * np.sinh(kh) - np.cosh(kh) + 1.0) / (np.sinh(2 * kh) + 2 * kh)


def jonswap_spectrum(f, hs: float, tp: float, gamma: float = 3.3):
    """JONSWAP variance density S(f) [m^2 s] at frequencies ``f`` [Hz] for significant wave height
    ``hs`` [m] and peak period ``tp`` [s], peak enhancement ``gamma`` (sigma 0.07 / 0.09), scaled so
    that ``4 sqrt(m0) = hs`` over f in (0, inf) (integrated numerically)."""
    fp = 1.0 / tp

    def shape(f):
        f = np.asarray(f, np.float64)
        sig = np.where(f <= fp, 0.07, 0.09)
        r = np.exp(-((f - fp) ** 2) / (2 * sig * sig * fp * fp))
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            s = f ** -5.0 * np.exp(-1.25 * (fp / f) ** 4) * gamma ** r
        return np.where(f > 0, s, 0.0)

    grid = np.linspace(0.05 * fp, 20 * fp, 40000)
    m0 = np.trapezoid(shape(grid), grid) if hasattr(np, "trapezoid") else np.trapz(shape(grid), grid)
    return shape(f) * (hs * hs / 16.0) / m0


# ---------------------------------------------------------------------------------------------
# paddle signals


@dataclasses.dataclass(frozen=True)
class PaddleSignal:
    """A paddle's displacement at the still water level against time, from a generator.

    Attributes:
      times: [N] s.  displacement: [N] m (0 at rest at the start).
      water_depth: m, the depth it was designed for.
      kind: "piston" or "flap", the transfer function it was designed with.
      info: what the generator aimed at (wave height, period, focus, seed ...).
    """

    times: np.ndarray
    displacement: np.ndarray
    water_depth: float
    kind: str = "piston"
    info: dict = dataclasses.field(default_factory=dict)

    @property
    def stroke(self) -> float:
        return float(np.ptp(self.displacement))

    def piston(self, direction=(1.0, 0.0, 0.0)) -> Table:
        """This signal as a piston's translation along ``direction``."""
        if self.kind != "piston":
            raise ValueError(f"PaddleSignal.piston: this signal was designed for a {self.kind} paddle "
                             f"(give kind='piston' to its generator)")
        return Table(self.times, self.displacement, direction=tuple(direction))

    def flap(self, hinge, axis=(0.0, 1.0, 0.0)) -> Flap:
        """This signal as a flap rotating about ``hinge`` [3] m (on the bed: the transfer function
        assumes it), ``axis``: the displacement X at the still water level, height ``lever`` =
        water depth above a bed hinge, is ``lever * tan(theta)``."""
        if self.kind != "flap":
            raise ValueError(f"PaddleSignal.flap: this signal was designed for a {self.kind} paddle "
                             f"(give kind='flap' to its generator)")
        lever = self.water_depth
        return Flap(self.times, np.arctan(self.displacement / lever), hinge=tuple(hinge), axis=tuple(axis),
                    lever=lever)


def _positive(name: str, v) -> float:
    v = float(v)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a finite number > 0 (got {v})")
    return v


def _transfer(kind: str):
    if kind == "piston":
        return piston_transfer
    if kind == "flap":
        return flap_transfer
    raise ValueError(f"kind must be 'piston' or 'flap' (got {kind!r})")


def _ramp(t, ramp: float):
    if ramp <= 0:
        return np.ones_like(t)
    return np.where(t < ramp, 0.5 * (1.0 - np.cos(np.pi * np.clip(t, 0, ramp) / ramp)), 1.0)


def _sum_of_sines(kind, water_depth, freqs, amplitudes, phases, duration, ramp, samples_per_period=40):
    """X(t) = taper(t) sum_n (a_n / F(k_n h)) sin(omega_n t + phase_n), tabulated; a half-cosine
    taper of ``ramp`` seconds at both ends so the paddle starts and stops at rest."""
    F = _transfer(kind)
    w = 2 * np.pi * np.asarray(freqs, np.float64)
    k = wavenumber(w, water_depth)
    dt = 1.0 / (samples_per_period * float(np.max(freqs)))
    n = int(math.ceil(duration / dt)) + 1
    t = np.linspace(0.0, duration, n)
    x = np.zeros_like(t)
    for a, wn, kn, ph in zip(np.asarray(amplitudes, np.float64), w, k, np.asarray(phases, np.float64)):
        x += (a / F(kn * water_depth)) * np.sin(wn * t + ph)
    taper = _ramp(t, ramp) * _ramp(duration - t, ramp)
    x = taper * x
    return t, x - x[0]


def regular(*, period: float, water_depth: float, duration: float, wave_height: float | None = None,
            stroke: float | None = None, ramp_periods: float = 2.0, kind: str = "piston") -> PaddleSignal:
    """A regular wave train: ``X = S/2 r(t) sin(2 pi t / T)`` with half-cosine ramps of
    ``ramp_periods`` periods at the start and end; give the target ``wave_height`` H (then S = H / F,
    Biesel's transfer function of ``kind``) or the ``stroke`` S."""
    T = _positive("regular: period", period)
    d = _positive("regular: water_depth", water_depth)
    dur = _positive("regular: duration", duration)
    if (wave_height is None) == (stroke is None):
        raise ValueError("regular: give exactly one of wave_height or stroke")
    k = float(wavenumber(2 * np.pi / T, d))
    F = float(_transfer(kind)(k * d))
    S = _positive("regular: stroke", stroke) if stroke is not None else _positive("regular: wave_height",
                                                                                  wave_height) / F
    if ramp_periods < 0 or 2 * ramp_periods * T > dur:
        raise ValueError(f"regular: ramp_periods must be >= 0 with both ramps within the duration "
                         f"(got {ramp_periods} periods of {T} s in {dur} s)")
    t, x = _sum_of_sines(kind, d, [1.0 / T], [0.5 * S * F], [0.0], dur, ramp_periods * T)
    return PaddleSignal(t, x, d, kind, dict(generator="regular", period=T, wave_height=S * F, stroke=S, kh=k * d))


def solitary(*, wave_height: float, water_depth: float, g: float = GRAVITY, tail: float = 1e-4,
             samples: int = 801, kind: str = "piston") -> PaddleSignal:
    """Goring's (1978) piston path for a solitary wave of height H in depth d.

    The paddle follows the water under the first-order (Boussinesq) solitary wave
    ``eta = H sech^2(K (c t - X))``, ``K = sqrt(3H / 4d^3)``, ``c = sqrt(g (d + H))``:
    ``dX/dt = c eta / (d + eta)``, whose solution is ``X = (H / K d) tanh(K (c t - X))``; the
    stroke is ``2H / (K d)``. Tabulated from ``tanh = -(1 - tail)`` to ``+(1 - tail)``, shifted to
    start at t = 0, X = 0. Only pistons (Goring's method assumes a depth-uniform paddle velocity).
    """
    if kind != "piston":
        raise ValueError("solitary: Goring's method is for a piston paddle (kind='piston')")
    H = _positive("solitary: wave_height", wave_height)
    d = _positive("solitary: water_depth", water_depth)
    if H / d > 0.6:
        raise ValueError(f"solitary: wave_height / water_depth = {H / d:.3g}; solitary waves break above ~0.6-0.78: "
                         f"give a smaller wave_height")
    K = math.sqrt(3 * H / (4 * d ** 3))
    c = math.sqrt(g * (d + H))
    th_end = math.atanh(1.0 - tail)
    # theta = K (c t - X) runs from -th_end to th_end; theta + (H/d) tanh(theta) = K c t
    theta = np.linspace(-th_end, th_end, samples)
    t = (theta + (H / d) * np.tanh(theta)) / (K * c)
    X = (H / (K * d)) * np.tanh(theta)
    t, X = t - t[0], X - X[0]
    return PaddleSignal(t, X, d, kind, dict(generator="solitary", wave_height=H, K=K, celerity=c,
                                            stroke=2 * H / (K * d), t_crest_at_paddle=float(t[samples // 2])))


def focused_group(*, amplitude: float, water_depth: float, f_min: float, f_max: float, x_focus: float,
                  t_focus: float, n_components: int = 32, spectrum: str = "uniform", ramp: float | None = None,
                  duration: float | None = None, kind: str = "piston") -> PaddleSignal:
    """A focused wave group: N linear components ``a_n cos(k_n (x - x_f) - omega_n (t - t_f))``
    with frequencies evenly spaced in ``[f_min, f_max]`` Hz, amplitudes summing to ``amplitude`` A
    (the linear crest at ``x_focus`` m from the paddle at ``t_focus`` s); ``spectrum``: "uniform"
    (equal a_n) or "jonswap" (a_n proportional to S(f_n) of a JONSWAP with the peak at the
    centre). The paddle runs from t = 0 to ``duration`` (default t_focus + 2 / f_min), tapered
    over ``ramp`` (default 1 / f_min) at each end."""
    A = _positive("focused_group: amplitude", amplitude)
    d = _positive("focused_group: water_depth", water_depth)
    f1, f2 = _positive("focused_group: f_min", f_min), _positive("focused_group: f_max", f_max)
    if f2 <= f1:
        raise ValueError("focused_group: f_max must be above f_min")
    tf = _positive("focused_group: t_focus", t_focus)
    ramp = 1.0 / f1 if ramp is None else float(ramp)
    if tf < 2 * ramp:
        raise ValueError(f"focused_group: t_focus = {tf} s leaves no time for the start-up taper ({ramp} s): "
                         f"give a later t_focus or a shorter ramp")
    dur = tf + 2.0 / f1 if duration is None else _positive("focused_group: duration", duration)
    f = np.linspace(f1, f2, int(n_components))
    if spectrum == "uniform":
        a = np.full(f.shape, A / f.size)
    elif spectrum == "jonswap":
        s = jonswap_spectrum(f, 1.0, 2.0 / (f1 + f2))
        a = A * s / s.sum()
    else:
        raise ValueError(f"focused_group: spectrum must be 'uniform' or 'jonswap' (got {spectrum!r})")
    k = wavenumber(2 * np.pi * f, d)
    phases = k * float(x_focus) - 2 * np.pi * f * tf
    t, x = _sum_of_sines(kind, d, f, a, phases, dur, ramp)
    return PaddleSignal(t, x, d, kind, dict(generator="focused_group", amplitude=A, x_focus=float(x_focus),
                                            t_focus=tf, f_min=f1, f_max=f2, n_components=int(n_components),
                                            freqs=f, amplitudes=a, phases=phases))


def jonswap(*, hs: float, tp: float, water_depth: float, duration: float, gamma: float = 3.3, seed: int = 0,
            n_components: int = 128, f_range=(0.5, 3.0), ramp: float | None = None,
            kind: str = "piston") -> PaddleSignal:
    """An irregular sea: random-phase linear components of a JONSWAP spectrum (significant height
    ``hs`` m, peak period ``tp`` s, ``gamma``), frequencies evenly spaced over ``f_range`` x f_p,
    amplitudes ``sqrt(2 S(f_n) df)``, phases uniform from ``numpy.random.default_rng(seed)``
    (the same seed gives the same sea), tapered over ``ramp`` (default 2 tp) at both ends."""
    hs_ = _positive("jonswap: hs", hs)
    tp_ = _positive("jonswap: tp", tp)
    d = _positive("jonswap: water_depth", water_depth)
    dur = _positive("jonswap: duration", duration)
    ramp = 2 * tp_ if ramp is None else float(ramp)
    if 2 * ramp >= dur:
        raise ValueError(f"jonswap: duration {dur} s is shorter than its two tapers (2 x {ramp} s)")
    fp = 1.0 / tp_
    f = np.linspace(f_range[0] * fp, f_range[1] * fp, int(n_components))
    df = f[1] - f[0]
    a = np.sqrt(2.0 * jonswap_spectrum(f, hs_, tp_, gamma) * df)
    phases = np.random.default_rng(int(seed)).uniform(0.0, 2 * np.pi, f.size)
    t, x = _sum_of_sines(kind, d, f, a, phases, dur, ramp)
    return PaddleSignal(t, x, d, kind, dict(generator="jonswap", hs=hs_, tp=tp_, gamma=gamma, seed=int(seed),
                                            n_components=int(n_components), freqs=f, amplitudes=a, phases=phases))


def read_csv(path, *, water_depth: float, kind: str = "piston", time_column: int = 0,
             displacement_column: int = 1) -> PaddleSignal:
    """A measured paddle record from a CSV file (t [s], displacement [m] columns; a header line
    and '#' comments are skipped), shifted to start at t = 0 from X = 0."""
    _transfer(kind)
    try:
        data = np.genfromtxt(path, delimiter=",", comments="#", skip_header=0)
    except OSError as e:
        raise ValueError(f"read_csv: cannot read {path}: {e}") from None
    data = np.atleast_2d(data)
    data = data[~np.all(np.isnan(data), axis=1)]
    if data.ndim != 2 or data.shape[1] <= max(time_column, displacement_column) or data.shape[0] < 2:
        raise ValueError(f"read_csv: {path} must hold at least 2 rows of (t, displacement) numbers")
    t, x = data[:, time_column], data[:, displacement_column]
    _check_table(f"read_csv({path})", t, x, 1)
    return PaddleSignal(t - t[0], x - x[0], _positive("read_csv: water_depth", water_depth), kind,
                        dict(generator="read_csv", file=str(path)))
