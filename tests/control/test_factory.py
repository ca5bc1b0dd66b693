"""The control factory: the registered controllers and references built from their own settings and the
run context, the config readers the sim layer calls, and the settings-only entry point."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.config import RunConfig, run_context, validate_config
from ftc_mj.config.sections import CONTROLLER_KINDS
from ftc_mj.control import (
    NMPC,
    CircleReference,
    LinearMPC,
    NMPCSettings,
    OpenLoopController,
    OpenLoopSettings,
    PathFollowingSettings,
    ReferenceSettings,
    RobustSettings,
    tracking_problem,
)
from ftc_mj.errors import BadInput
from ftc_mj.registry import controllers, references
from ftc_mj.wiring.control import build_controller, build_reference, controller_from_settings, problem_spec
from tests.control.common import NOMINAL, cfg_with, problem


def test_factory_kinds() -> None:
    cfg = cfg_with(kind="open-loop", open_loop_omega=(3.0, 4.0))
    ctl = build_controller(cfg, build_reference(cfg))
    assert isinstance(ctl, OpenLoopController)
    np.testing.assert_allclose(ctl.solve(0.0, np.zeros(3), np.array(NOMINAL)).omega, [3.0, 4.0])
    assert isinstance(build_controller(cfg_with(kind="lmpc"), build_reference(cfg)), LinearMPC)
    with pytest.raises(ValueError):
        NMPC(problem(), build_reference(cfg), solver="bogus")


def test_factories_take_their_own_settings_and_the_run_context() -> None:
    """Every built-in controller and reference factory follows the component contract (own settings, the run
    context, then the reference); the problem numbers come from the controller section and the context."""
    for reg in (controllers, references):
        for name in reg.names():
            entry = reg.get(name)
            if entry.origin == "built-in":
                assert not entry.legacy, f"{reg.kind} {name!r} takes the whole run config"
    cfg = RunConfig()
    cfg.controller.nodes = 20
    ctx = run_context(cfg)
    spec = tracking_problem(cfg.controller, ctx)
    assert spec == problem_spec(cfg)
    assert (spec.nodes, spec.half_track, spec.omega_max, spec.sample_time) == (20, ctx.half_track, ctx.omega_max,
                                                                                ctx.controller_dt)
    ref = references.create("circle", cfg.reference, ctx)
    assert isinstance(ref, CircleReference) and ref.speed == cfg.reference.speed
    ctl = controllers.create("open-loop", OpenLoopSettings(), ctx, ref)
    assert isinstance(ctl, OpenLoopController)


def test_each_builtin_is_registered_with_its_settings_model() -> None:
    """Every built-in controller is registered with the settings model of its kind (``section``), the model the
    config's ``[controller]`` union picks for that kind; every built-in reference with the reference model."""
    for name in controllers.names():
        entry = controllers.get(name)
        if entry.origin == "built-in":
            model = entry.meta["section"]
            assert CONTROLLER_KINDS[name] is model and model().kind == name
            assert type(RunConfig(controller={"kind": name}).controller) is model
    for name in references.names():
        if references.get(name).origin == "built-in":
            assert references.get(name).meta["section"] is ReferenceSettings


def test_controller_from_settings_alone() -> None:
    """``controller_from_settings`` builds the controller its section names from plain tables."""
    ref = CircleReference()
    ctl = controller_from_settings({"kind": "open-loop", "open_loop_omega": [1.0, 2.0]}, ref,
                                   robot={"omega_max": 1.5})
    np.testing.assert_allclose(ctl.solve(0.0, np.zeros(3), np.array(NOMINAL)).omega, [1.0, 1.5])


def test_an_old_controller_plugin_still_builds_with_a_warning() -> None:
    """A plug-in factory of the old contract, ``factory(cfg, reference)``, is still called by
    ``build_controller`` with the whole run config, behind a one-line DeprecationWarning."""
    seen = []

    def old(cfg, reference):
        seen.append((cfg, reference))
        return OpenLoopController((1.0, 1.0))

    controllers.register("probe-old-controller", old)
    try:
        cfg = RunConfig(controller={"kind": "probe-old-controller"})
        assert cfg.controller.options == {} and cfg.controller.nodes == 50  # a plug-in's section: the MPC's
        ref = build_reference(cfg)
        with pytest.warns(DeprecationWarning, match="old contract"):
            ctl = build_controller(cfg, ref)
        assert isinstance(ctl, OpenLoopController) and seen == [(cfg, ref)]
    finally:
        controllers.unregister("probe-old-controller")


def test_a_flat_controller_table_of_defaults_still_reads() -> None:
    """A resolved config written when ``[controller]`` was one flat table (every kind's settings, the other
    kinds' at their defaults) reads as the same run; another kind's setting away from its default is a one-line
    error naming it and the kinds that have it."""
    flat = {"kind": "nmpc", "nodes": 20, "open_loop_omega": [5.0, 5.0], "open_loop_schedule": [],
            "lmpc_qpsol": "daqp", "options": {}, "path_following": PathFollowingSettings().model_dump(),
            "robust": {**RobustSettings().model_dump(), "scenarios": [[1.0, 1.0], [0.5, 1.0], [1.0, 0.5], [0.5, 0.5]]}}
    cfg = validate_config({"controller": flat})
    assert cfg.controller == NMPCSettings(nodes=20)
    with pytest.raises(BadInput, match=r"^controller.lmpc_qpsol: not a setting of controller 'nmpc' \(a setting "
                                       r"of lmpc\)$"):
        validate_config({"controller": {**flat, "lmpc_qpsol": "osqp"}})
    with pytest.raises(BadInput, match=r"^controller.robust: not a setting of controller 'nmpc'"):
        validate_config({"controller": {**flat, "robust": {"objective": "worst"}}})
