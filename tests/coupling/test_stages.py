"""A scene traces only the stages it needs (DESIGN "Skip what a scene does not need").

Each test replaces the functions of the stage that must be absent by ones that raise, then
traces the step: tracing succeeds only if the stage is never called.
"""

import jax

import rockjax as rj
from rockjax import blocks
from rockjax.coupling import penalty
from rockjax import step as step_module
from rockjax.sph import neighbours, seed, wcsph


def _boom(*a, **k):
    raise AssertionError("a stage that this scene does not need was traced")


def test_fluid_only_scene_traces_no_block_or_coupling_code(monkeypatch):
    scene = rj.scenes.hydrostatic_tank(dx=0.05, length=0.2, width=0.2, depth=0.2)
    assert scene.config.blocks is None
    monkeypatch.setattr(blocks, "advance_blocks", _boom)
    monkeypatch.setattr(penalty, "apply", _boom)
    monkeypatch.setattr(penalty, "load", _boom)
    step = rj.make_step(scene.config)
    jax.make_jaxpr(step)(scene.state, scene.params)  # would raise if block code were traced


def test_blocks_only_scene_traces_no_sph_code(monkeypatch):
    scene = rj.scenes.block_on_incline(angle_deg=20.0, friction_angle_deg=30.0)
    assert scene.config.n_fluid == 0 and scene.state.particles is None
    for mod, name in ((wcsph, "advance"), (seed, "advance"), (neighbours, "rebuild"), (step_module, "rebuild"),
                      (penalty, "apply")):
        monkeypatch.setattr(mod, name, _boom)
    step = rj.make_step(scene.config)
    jax.make_jaxpr(step)(scene.state, scene.params)


def test_coupled_scene_traces_both(monkeypatch):
    scene = rj.scenes.block_drop(dx=0.05, box_size=(0.1, 0.1, 0.1), tank_size=(0.3, 0.3), water_depth=0.15)
    called = []
    real = blocks.advance_blocks

    def spy(*a, **k):
        called.append(1)
        return real(*a, **k)

    monkeypatch.setattr(blocks, "advance_blocks", spy)
    step = rj.make_step(scene.config)
    jax.make_jaxpr(step)(scene.state, scene.params)
    assert called, "the coupled scene must trace the block stage"


def test_joint_water_traced_only_when_on(monkeypatch):
    """``BlockConfig.joint_water`` off (block_on_incline, no water): the joint-water code is never
    traced; on (block_drop's default): it is."""
    from rockjax.blocks import contact

    scene = rj.scenes.block_on_incline(angle_deg=20.0, friction_angle_deg=30.0)
    assert not scene.config.blocks.joint_water
    monkeypatch.setattr(contact, "joint_water_load", _boom)
    jax.make_jaxpr(rj.make_step(scene.config))(scene.state, scene.params)
    wet = rj.scenes.block_drop(dx=0.05, box_size=(0.1, 0.1, 0.1), tank_size=(0.3, 0.3), water_depth=0.15)
    assert wet.config.blocks.joint_water
    try:
        jax.make_jaxpr(rj.make_step(wet.config))(wet.state, wet.params)
    except AssertionError:
        return
    raise AssertionError("block_drop (joint water on) did not trace the joint-water code")
