"""Registry, third-party optimisers and entry-point plug-ins (optimizers.md §1, §10)."""

from __future__ import annotations

import dataclasses
import functools
import importlib.metadata
import sys
import types

import numpy as np
import pytest

import optimizers
from optimizers import (
    Optimizer,
    OptimizeResult,
    available_optimizers,
    get_optimizer,
    register_optimizer,
    registry,
)
from optimizers.base import BudgetedObjective, normalize_bounds
from optimizers.hpso import HPSO
from optimizers.ihpso import IHPSO
from optimizers.mcpso import MCPSO
from optimizers.ps2o import PS2O
from optimizers.pso import PSO

SECTION_10 = {
    "ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism", "pso", "pso-ldw", "cem", "de", "cmaes",
    "cmaes-default", "ihpso-scheme1", "ihpso-scheme2", "ihpso-scheme3", "ihpso-random", "ihpso-noterm",
    "ihpso-literal", "hpso-literal", "ps2o-noext", "mcpso-com", "ihpso-noswitch", "ihpso-noreverse",
    "ihpso-2022v0", "ihpso-rtol1e-6", "ihpso-rtol1e-5", "ihpso-rtol1e-3", "ihpso-rtol1e-2",
}


@pytest.fixture
def fresh_registry(monkeypatch):
    """A copy of the registry, so registrations made by a test do not leak."""
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    return registry._REGISTRY


def test_every_section_10_configuration_is_registered():
    assert SECTION_10 <= set(available_optimizers())
    assert available_optimizers() == sorted(available_optimizers())


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("ihpso", IHPSO()),
        ("ihpso-scheme1", IHPSO(scheme=("cluster", "cluster"))),
        ("ihpso-scheme2", IHPSO(scheme=("entropy", "entropy"))),
        ("ihpso-scheme3", IHPSO(scheme=("cluster", "entropy"))),
        ("ihpso-random", IHPSO(scheme=("random", "random"))),
        ("ihpso-noterm", IHPSO(terminate=False)),
        ("ihpso-literal", IHPSO(constriction=1.0, stage2_sign=-1)),
        ("ihpso-noswitch", IHPSO(switch=False)),
        ("ihpso-noreverse", IHPSO(reverse_switch=False)),
        ("ihpso-2022v0", IHPSO(linkage="average", grouping_cut="equal", spread="sum", level="mean",
                               slope_rtol=1e-9)),
        ("ihpso-rtol1e-6", IHPSO(slope_rtol=1e-6)),
        ("ihpso-rtol1e-2", IHPSO(slope_rtol=1e-2)),
        ("hpso-literal", HPSO(constriction=1.0, stage2_sign=-1)),
        ("ps2o-noext", PS2O(extinction_patience=None)),
        ("mcpso", MCPSO(version="col")),
        ("mcpso-com", MCPSO(version="com")),
        ("pso-ldw", PSO(variant="ldw", cognitive=2.0, social=2.0)),
    ],
)
def test_configurations_have_the_section_10_overrides(name, expected):
    assert get_optimizer(name) == expected


def test_overrides_and_instances_are_fresh():
    opt = get_optimizer("ihpso-scheme1", swarm_size=40)
    assert opt.swarm_size == 40 and opt.scheme == ("cluster", "cluster")
    assert get_optimizer("ihpso") is not get_optimizer("ihpso")
    with pytest.raises(TypeError, match=r"no parameter 'swarm'.*swarm_size"):
        get_optimizer("pso", swarm=3)
    with pytest.raises(ValueError, match=r"PSO\.swarm_size: got 0"):
        get_optimizer("pso", swarm_size=0)


def test_unknown_name_message():
    with pytest.raises(KeyError) as err:
        get_optimizer("ihspo")
    message = err.value.args[0]
    assert message.startswith("unknown optimizer 'ihspo' — did you mean 'ihpso'")
    assert message.endswith("available: " + ", ".join(available_optimizers()))
    with pytest.raises(KeyError) as err:
        get_optimizer("zzzz")
    assert "did you mean" not in err.value.args[0]


def test_duplicate_and_bad_names(fresh_registry):
    with pytest.raises(ValueError, match="already registered"):
        register_optimizer("ihpso")(IHPSO)
    with pytest.raises(ValueError, match="non-empty"):
        register_optimizer("")
    with pytest.raises(TypeError):
        register_optimizer("not-callable")(42)


@dataclasses.dataclass(frozen=True)
class RandomSearch:
    """A third-party optimiser: uniform random search, built only on the public interface."""

    batch: int = 50

    def minimize(self, fun, bounds, *, rng=None, max_evals=10_000, x0=None) -> OptimizeResult:
        rng = np.random.default_rng(rng)
        lo, hi = normalize_bounds(bounds)
        objective = BudgetedObjective(fun, lo.shape[0], max_evals)
        batches = 0
        while objective.remaining > 0:
            x = lo + rng.random((self.batch, lo.shape[0])) * (hi - lo)
            if batches == 0 and x0 is not None:
                x[0] = np.clip(x0, lo, hi)
            objective(x)
            objective.record()
            batches += 1
        return objective.result(batches - 1, "max_evals reached")


def test_third_party_optimizer_through_the_registry(fresh_registry):
    register_optimizer("random-search")(RandomSearch)
    assert "random-search" in available_optimizers()
    opt = get_optimizer("random-search", batch=20)
    assert isinstance(opt, Optimizer) and opt.batch == 20
    res = opt.minimize(lambda x: (x**2).sum(axis=1), [(-1.0, 1.0)] * 3, rng=0, max_evals=100)
    assert res.nfev == 100 and res.nit == 4 and res.fun < 0.5


def test_partial_and_factory_registrations(fresh_registry):
    register_optimizer("small-pso")(functools.partial(PSO, swarm_size=10))
    assert get_optimizer("small-pso") == PSO(swarm_size=10)
    assert get_optimizer("small-pso", social=1.0) == PSO(swarm_size=10, social=1.0)

    @register_optimizer("factory-pso")
    def make():
        return PSO(swarm_size=20)

    assert get_optimizer("factory-pso").swarm_size == 20
    assert get_optimizer("factory-pso", swarm_size=30).swarm_size == 30


class FakeEntryPoint:
    def __init__(self, name, value, loader):
        self.name, self.value, self.group = name, value, registry.ENTRY_POINT_GROUP
        self._loader = loader

    def load(self):
        return self._loader()


@pytest.fixture
def plugins(monkeypatch, fresh_registry):
    """Pretend that a few packages declare optimiser plug-ins."""
    queried = []

    def install(*entry_points):
        def fake_entry_points(**kwargs):
            queried.append(kwargs)
            return list(entry_points)

        monkeypatch.setattr(importlib.metadata, "entry_points", fake_entry_points)
        monkeypatch.setattr(registry, "_plugins_loaded", False)
        return queried

    return install


def test_entry_point_plugin_module_registers_on_import(plugins, monkeypatch):
    module = types.ModuleType("uav_test_plugin")
    module.__dict__["run_on_import"] = lambda: register_optimizer("plugin-search")(RandomSearch)

    def load_module():
        module.run_on_import()
        return module

    queried = plugins(FakeEntryPoint("plugin", "uav_test_plugin", load_module))
    assert "plugin-search" in available_optimizers()
    assert queried == [{"group": "uav_penetration.optimizers"}]
    assert isinstance(get_optimizer("plugin-search"), RandomSearch)
    available_optimizers()
    assert len(queried) == 1  # loaded once


def test_entry_point_plugin_loaded_through_importlib(plugins, monkeypatch):
    module = types.ModuleType("uav_test_plugin_mod")
    exec(
        "import functools\n"
        "from optimizers import register_optimizer\n"
        "from optimizers.pso import PSO\n"
        "register_optimizer('imported-search')(functools.partial(PSO, swarm_size=7))\n",
        module.__dict__,
    )
    monkeypatch.setitem(sys.modules, "uav_test_plugin_mod", module)
    ep = importlib.metadata.EntryPoint(name="imported", value="uav_test_plugin_mod",
                                       group=registry.ENTRY_POINT_GROUP)
    plugins(ep)
    assert "imported-search" in available_optimizers()
    assert get_optimizer("imported-search") == PSO(swarm_size=7)


def test_entry_point_callable_is_registered_under_its_name(plugins):
    plugins(FakeEntryPoint("bare-search", "pkg:RandomSearch", lambda: RandomSearch))
    assert isinstance(get_optimizer("bare-search"), RandomSearch)


def test_broken_plugin_warns_and_does_not_break_the_registry(plugins):
    def broken():
        raise ImportError("No module named 'missing_dependency'")

    plugins(FakeEntryPoint("broken", "broken_pkg.module", broken))
    with pytest.warns(registry.OptimizerPluginWarning, match="'broken'.*broken_pkg.module.*missing_dependency"):
        names = available_optimizers()
    assert "ihpso" in names


def test_public_names():
    assert set(optimizers.__all__) >= {
        "get_optimizer", "available_optimizers", "register_optimizer", "Optimizer", "OptimizeResult",
        "BudgetedObjective",
    }
