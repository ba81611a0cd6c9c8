"""Reference data and metrics used by the physics tests and the experiments.

``martin_moyce_n2_2()`` loads Martin & Moyce (1952), Table 2 (tall column n^2 = 2) from the
project's ``data/validation`` copy (see that file's header for sources); ``dam_break_2d`` builds
that experiment as a periodic slab, ``dam_break_3d`` as a 3D tank with side walls, and
``front_error`` compares a simulated front with it. ``energy_history`` evaluates the total
energy of every frame of a run (both schemes) for the closed-tank energy checks.
``piston_transfer``, ``linear_wave`` and ``wave_height`` are the piston wave-maker check: linear
theory's H/S (tabulated), the dispersion relation, and the height of a recorded wave train;
``wave_mode`` the frequency and decay of the wave in a periodic box (``scenes.wave_box``);
``reflection`` splits gauge records into incident and reflected waves (Mansard & Funke 1980);
``solitary_profile`` and ``synolakis_runup`` are the solitary wave's closed forms;
``hoek_bray_regime`` is the block-on-a-plane failure mode (sliding, toppling, both, stable).
"""

from __future__ import annotations

import math
import pathlib

import numpy as np

__all__ = ["data_dir", "martin_moyce_n2_2", "dam_break_2d", "dam_break_3d", "front_history", "front_error",
           "energy_history", "piston_transfer", "linear_wave", "wave_height", "wave_phase", "wave_mode", "reflection",
           "synolakis_runup", "solitary_profile"]

GRAVITY = 9.81


def data_dir() -> pathlib.Path:
    """The repository's ``data/validation`` directory (source checkout)."""
    return pathlib.Path(__file__).resolve().parents[2] / "data" / "validation"


def martin_moyce_n2_2(src: str = "T2"):
    """(T, Z) arrays of the n^2 = 2 surge front, T = t sqrt(2 g / a), Z = z / a, 0 < T <= 3."""
    path = data_dir() / "martin_moyce_1952_surge_front_n2_2.csv"
    rows = [ln.split(",") for ln in path.read_text().splitlines() if ln and not ln.startswith("#")][1:]
    T = np.array([float(r[0]) for r in rows if r[3].strip() == src])
    Z = np.array([float(r[2]) for r in rows if r[3].strip() == src])
    keep = (T > 0) & (T <= 3.0)
    return T[keep], Z[keep]


def dam_break_2d(*, a: float = 0.1, resolution: int = 20, **kwargs):
    """Martin & Moyce's n^2 = 2 column (width a, height 2a) as a periodic slab, tank 5a long."""
    from .scenes import dam_break

    dx = a / resolution
    width = 7 * dx
    return dam_break(dx=dx, column_length=a, column_width=width, column_height=2 * a, tank_length=5 * a,
                     tank_width=width, tank_height=3 * a, periodic_y=True, **kwargs)


def dam_break_3d(*, a: float = 0.1, resolution: int = 8, width: float | None = None, **kwargs):
    """Martin & Moyce's n^2 = 2 column (a x width x 2a) across a walled tank 5a long, ``width`` wide.

    3D with real side walls (no periodic axis), the column spanning the tank width as in the
    experiment. ``width`` defaults to ``a``. ``kwargs`` go to ``scenes.dam_break``.
    """
    from .scenes import dam_break

    dx = a / resolution
    width = a if width is None else float(width)
    return dam_break(dx=dx, column_length=a, column_width=width, column_height=2 * a, tank_length=5 * a,
                     tank_width=width, tank_height=3 * a, periodic_y=False, **kwargs)


def front_history(result, *, a: float):
    """(T, Z) of the simulated front from ``simulate`` frames: Z = (max x of fluid with z < 0.1 a + dx/2) / a."""
    dx = result.scene.meta["dx"]
    fluid = result.frames["kind"][0] == 0
    x = result.frames["x"][:, fluid, :]
    low = x[..., 2] < 0.1 * a
    front = np.where(low, x[..., 0], -np.inf).max(axis=1) + 0.5 * dx
    T = result.times * math.sqrt(2 * 9.81 / a)
    return T, front / a


def front_error(T_sim, Z_sim, T_ref, Z_ref, *, shift: float = 0.0) -> float:
    """RMS relative error of Z_sim(T - shift), interpolated at the reference times."""
    z = np.interp(T_ref - shift, T_sim, Z_sim)
    return float(np.sqrt(np.mean(((z - Z_ref) / Z_ref) ** 2)))


def energy_history(result, *, stride: int = 1) -> dict:
    """Energies [J] of the fluid at every ``stride``-th frame of a ``simulate`` result (host arrays).

    Each frame becomes a state (positions, velocities, densities of the frame), its neighbour list
    is rebuilt, and the scheme's energy is evaluated: WCSPH ``observables.energies`` (kinetic +
    potential + Tait elastic energy of the carried density), seed ``sph.seed.energies`` (density
    re-summed at the frame's positions, clamped elastic energy, wall-spring energy). Returns a dict
    of [F] arrays (``t``, ``kinetic``, ``potential``, ``elastic``, ``total``, and ``wall`` for seed).
    """
    import jax
    import jax.numpy as jnp

    from .observables import energies
    from .sph import seed
    from .step import refresh
    from .sph.schemes import SeedScheme

    scene = result.scene
    config, params = scene.config, scene.params
    state = scene.state
    order = np.argsort(np.asarray(state.particles.pid))  # frames are in original particle order
    base = jax.tree_util.tree_map(lambda a: a[order], state.particles)

    @jax.jit
    def one(x, v, rho):
        P = base.replace(x=jnp.asarray(x, base.x.dtype), v=jnp.asarray(v, base.v.dtype),
                         rho=jnp.asarray(rho, base.rho.dtype))
        st = refresh(state.replace(particles=P), config)
        if isinstance(config.scheme, SeedScheme):
            return seed.energies(st.particles, st.nbrs, params, config)
        return energies(st, params, config)

    F = result.frames
    out: dict = {}
    keep = list(range(0, len(result.times), stride))
    for k in keep:
        e = one(F["x"][k], F["v"][k], F["rho"][k])
        for name, val in e.items():
            out.setdefault(name, []).append(float(val))
    out = {k: np.asarray(v) for k, v in out.items()}
    out["t"] = np.asarray(result.times)[keep]
    return out


def piston_transfer(kh: float) -> float:
    """Linear piston wave-maker theory H/S = 2 (cosh 2kh - 1) / (sinh 2kh + 2kh) (Dean & Dalrymple
    1991), interpolated from ``data/validation/piston_wavemaker_transfer.csv`` (source in its header)."""
    path = data_dir() / "piston_wavemaker_transfer.csv"
    rows = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#") and not ln.startswith("kh")]
    tab = np.array([[float(v) for v in ln.split(",")[:2]] for ln in rows])
    return float(np.interp(kh, tab[:, 0], tab[:, 1]))


def linear_wave(kh: float, depth: float, *, g: float = GRAVITY) -> dict:
    """Linear (Airy) wave of relative depth ``kh`` in water ``depth`` [m]: ``k`` [1/m], ``omega``
    [1/s], ``period`` [s], phase speed ``c`` and group speed ``cg`` [m/s]."""
    k = kh / depth
    omega = math.sqrt(g * k * math.tanh(kh))
    cg = 0.5 * omega / k * (1.0 + 2.0 * kh / math.sinh(2.0 * kh))
    return dict(k=k, omega=omega, period=2 * math.pi / omega, c=omega / k, cg=cg)


def wave_mode(t, eta, x, *, k: float, t_start: float = 0.0) -> dict:
    """The first Fourier mode of surface records over one periodic wavelength (``scenes.wave_box``).

    ``eta`` [F, M] m at gauges ``x`` [M] m spread evenly over the period ``2 pi / k``, frames ``t``
    [F] s. The mode ``A(t) = (2 / M) sum_j eta_j exp(-i k x_j)`` (a progressive wave
    ``a cos(kx - omega t)`` gives ``a exp(-i omega t)``); fitted from ``t_start`` on: ``omega``
    [1/s] (the slope of its unwrapped phase) and ``mu`` [1/s] (of ``-ln |A|``, the amplitude's
    decay rate). Returns ``amplitude`` [F] m, ``omega``, ``mu``."""
    t, eta, x = np.asarray(t, float), np.asarray(eta, float), np.asarray(x, float)
    mode = 2.0 / x.size * (eta @ np.exp(-1j * k * x))
    amp = np.abs(mode)
    keep = t >= t_start
    mu = -np.polyfit(t[keep], np.log(amp[keep]), 1)[0]
    omega = -np.polyfit(t[keep], np.unwrap(np.angle(mode[keep])), 1)[0]
    return dict(amplitude=amp, omega=float(omega), mu=float(mu))


def _harmonic_fit(t, eta, period: float, t_start: float, t_stop: float):
    """Least-squares coefficients ``(a1, b1, a2, b2, c0, c1)`` of ``wave_height``'s model over the
    whole periods in ``[t_start, t_stop]``, and their number (None, 0 when not one period fits)."""
    t = np.asarray(t, float)
    eta = np.asarray(eta, float)
    n = int(math.floor((t_stop - t_start) / period + 1e-9))
    if n < 1:
        return None, 0
    m = (t >= t_start) & (t < t_start + n * period)
    w = 2 * math.pi / period
    tm = t[m]
    A = np.stack([np.sin(w * tm), np.cos(w * tm), np.sin(2 * w * tm), np.cos(2 * w * tm), np.ones_like(tm),
                  tm - tm.mean()], 1)
    return np.linalg.lstsq(A, eta[m], rcond=None)[0], n


def wave_height(t, eta, *, period: float, t_start: float, t_stop: float) -> tuple[float, float, int]:
    """Height of the wave train ``eta(t)`` [m] at the frequency 2 pi / ``period``.

    Least squares over the whole periods that fit in ``[t_start, t_stop]`` of
    ``eta ~ a1 sin(w t) + b1 cos(w t) + a2 sin(2 w t) + b2 cos(2 w t) + c0 + c1 t`` (the second
    harmonic that a sinusoidal paddle makes, and a slow drift of the mean level). Returns
    ``(H, H2, n_periods)``: the first- and second-harmonic heights ``2 |(a, b)|`` [m] and the number
    of periods fitted (0, with NaN heights, when not one period fits).
    """
    c, n = _harmonic_fit(t, eta, period, t_start, t_stop)
    if c is None:
        return float("nan"), float("nan"), 0
    return 2 * math.hypot(c[0], c[1]), 2 * math.hypot(c[2], c[3]), n


def wave_phase(t, eta, *, period: float, t_start: float, t_stop: float) -> float:
    """Phase ``phi`` [rad] of the first harmonic, ``eta_1 = (H/2) cos(w t - phi)``, fitted like
    ``wave_height``. For a progressive wave ``eta = (H/2) cos(w t - k x)`` at gauge x, ``phi = k x``
    (mod 2 pi): the slope of the unwrapped phases over gauges is the wavenumber k. NaN when not
    one period fits."""
    c, _ = _harmonic_fit(t, eta, period, t_start, t_stop)
    if c is None:
        return float("nan")
    return math.atan2(c[0], c[1])


def reflection(t, eta, x, *, period: float, depth: float, t_start: float, t_stop: float, k: float | None = None,
               g: float = GRAVITY) -> dict:
    """Incident and reflected regular waves from records at several gauges (Mansard & Funke 1980,
    least squares at the first harmonic).

    Each gauge's first harmonic ``Z_p`` (complex amplitude: ``eta_1 = Re(Z_p e^{i w t})``, fitted
    like ``wave_height`` over the whole periods in ``[t_start, t_stop]``) is modelled as
    ``A e^{-i k x_p} + B e^{+i k x_p}``: a wave travelling towards +x (A) and one towards -x (B);
    A and B solve the least-squares system over the gauges. ``k`` defaults to linear theory's.

    Args:
      t: [T] s.  eta: [T, G] m, one column per gauge.  x: [G] m, gauge positions (G >= 2, not
      spaced by a multiple of half a wavelength: the system is singular there).
    Returns:
      dict with ``H_incident``, ``H_reflected`` (m, 2|A|, 2|B|), ``Kr`` = |B| / |A|, ``k`` (1/m),
      ``periods`` fitted and ``condition`` (of the gauge matrix; above ~10 the split is unreliable).
    """
    eta = np.asarray(eta, float)
    x = np.asarray(x, float)
    if eta.ndim != 2 or eta.shape[1] != x.size or x.size < 2:
        raise ValueError(f"reflection: eta must be [T, G] with G = len(x) >= 2 gauges (got {eta.shape}, {x.size})")
    if k is None:
        w = 2 * math.pi / period
        from .blocks.paths import wavenumber

        k = float(wavenumber(w, depth, g))
    Z = []
    n = 0
    for j in range(x.size):
        c, n = _harmonic_fit(t, eta[:, j], period, t_start, t_stop)
        if c is None:
            raise ValueError(f"reflection: [t_start, t_stop] = [{t_start}, {t_stop}] s holds no whole period of {period} s")
        Z.append(c[1] - 1j * c[0])  # a sin + b cos = Re((b - i a) e^{i w t})
    M = np.stack([np.exp(-1j * k * x), np.exp(1j * k * x)], 1)
    (A, B), *_ = np.linalg.lstsq(M, np.asarray(Z), rcond=None)
    return dict(H_incident=2 * abs(A), H_reflected=2 * abs(B), Kr=abs(B) / abs(A), k=k, periods=n,
                condition=float(np.linalg.cond(M)))


def solitary_profile(x, t, *, wave_height: float, depth: float, x0: float = 0.0, g: float = GRAVITY):
    """First-order (Boussinesq) solitary wave ``eta = H sech^2(K (x - x0 - c t))``,
    ``K = sqrt(3 H / 4 d^3)``, ``c = sqrt(g (d + H))`` [m]."""
    K = math.sqrt(3 * wave_height / (4 * depth ** 3))
    c = math.sqrt(g * (depth + wave_height))
    return wave_height / np.cosh(K * (np.asarray(x, float) - x0 - c * np.asarray(t, float))) ** 2


def synolakis_runup(*, wave_height: float, depth: float, beach_slope: float) -> float:
    """Synolakis (1987) run-up law of non-breaking solitary waves on a plane beach:
    ``R / d = 2.831 sqrt(cot beta) (H / d)^(5/4)`` [m] (``beach_slope`` = tan beta, rise / run).
    Valid for non-breaking waves, ``H / d < 0.818 (cot beta)^(-10/9)``."""
    cot = 1.0 / beach_slope
    return depth * 2.831 * math.sqrt(cot) * (wave_height / depth) ** 1.25


def hoek_bray_regime(*, plane_dip_deg: float, friction_angle_deg: float, base: float, height: float) -> str:
    """How a rectangular block of ``base`` (along the dip) x ``height`` [m] resting on a plane
    dipping ``plane_dip_deg`` with friction ``friction_angle_deg`` fails (Hoek & Bray 1981, Rock
    Slope Engineering, 3rd ed., fig. 9.2; Goodman & Bray 1976): it slides when the dip exceeds the
    friction angle, and topples when its weight's line of action falls outside its base,
    ``base / height < tan(dip)``. Returns "stable", "sliding", "toppling" or "sliding_and_toppling".
    The chart, not the onset dynamics: near its lines a toppling block's pivot may slip or a
    sliding one tip (tests/blocks/test_physics.py ``expected_regime`` checks both views)."""
    slides = plane_dip_deg > friction_angle_deg
    topples = base / height < math.tan(math.radians(plane_dip_deg))
    return {(False, False): "stable", (True, False): "sliding", (False, True): "toppling",
            (True, True): "sliding_and_toppling"}[(slides, topples)]
