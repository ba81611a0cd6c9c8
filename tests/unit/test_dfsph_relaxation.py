"""DFSPH's Jacobi relaxation against its stability bound ``2 / lambda_max`` (``dfsph.jacobi_lambda_max``).

The bound is the bulk lattice's symbol of the solves' operator; it must predict where the sweeps
diverge: a tank at rest (10 x 10 x 10 particles) with the cubic spline at h = 1.4 dx (bound 0.326)
holds at relaxation 0.3 and blows up at 0.4 (walls and the free surface lower the operator's top
eigenvalue: 0.34 held 0.3 s, 0.36 failed at step 9, 0.4 at step 1); a scene that asks for a
relaxation above the bound is refused at its build.
"""

import pytest

import rockjax as rj
from rockjax.sph.dfsph import jacobi_lambda_max
from rockjax.sph.kernels import CubicSpline, WendlandC2


def test_lambda_max_of_the_lattice():
    # the values the solves were tuned on (the DFSPH docstring's measured lambda_max) and monotone in h
    assert jacobi_lambda_max(WendlandC2(), 1.3) == pytest.approx(4.20, abs=0.01)
    assert jacobi_lambda_max(CubicSpline(), 1.0) == pytest.approx(2.82, abs=0.01)
    lams = [jacobi_lambda_max(CubicSpline(), hf) for hf in (1.0, 1.2, 1.4, 1.5)]
    assert all(a < b for a, b in zip(lams, lams[1:]))
    assert 2.0 / jacobi_lambda_max(CubicSpline(), 1.4) == pytest.approx(0.326, abs=0.002)


def _tank(relaxation):
    return rj.scenes.hydrostatic_tank(dx=0.02, length=0.2, width=0.2, depth=0.2, h_factor=1.4,
                                      scheme=rj.DFSPH(relaxation=relaxation))


def test_the_bound_says_where_the_sweeps_diverge():
    rj.simulate(_tank(0.3), t_end=0.2, progress=False)  # below 0.326: holds (raises otherwise)
    with pytest.raises(ValueError, match=r"relaxation = 0.36 is at or above .* 0.326 .*h = 1.4 dx"):
        _tank(0.36)
    # the same solve with the check bypassed diverges
    sc = _tank(0.3)
    sc = sc.replace(config=sc.config.replace(scheme=rj.DFSPH(relaxation=0.4)))
    with pytest.raises(rj.SimulationError, match="UNSTABLE_DT|SOLVER_NOT_CONVERGED|OUT_OF_DOMAIN"):
        rj.simulate(sc, t_end=0.2, progress=False)


def test_refused_for_the_scenes_that_take_h_factor():
    with pytest.raises(ValueError, match=r"DFSPH: relaxation = 0.4 .* 0.268 of the cubic_spline kernel at h = 1.5 dx"):
        rj.scenes.hydrostatic_tank(dx=0.05, h_factor=1.5, scheme=rj.DFSPH())
    with pytest.raises(ValueError, match=r"DFSPH: relaxation = 0.4"):
        rj.scenes.sliding_wedge(dx=0.05, h_factor=1.5, scheme="dfsph", coupling=rj.Coupling.BOUNDARY_PARTICLES)
    assert rj.scenes.hydrostatic_tank(dx=0.05, h_factor=1.5, scheme=rj.DFSPH(relaxation=0.24)).config.n_fluid > 0
