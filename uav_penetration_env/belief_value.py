"""V of a changing belief, rebuilt incrementally from the previous belief's (docs/dynamic.md §4, model.md §7e.2).

When a dynamic scenario's belief changes (a radar revealed, a tracked one moved), a planner that
reads the lattice value function V needs V of the new belief's model. :func:`advance_value_function`
rebuilds it from the previous belief's builder (:meth:`ValueFunctionBuilder.with_model`: only the
changed radars' threats and the moves and nodes they touch) and places it where
:func:`~uav_penetration_env.value_function.value_function` finds it for the new model, so the
terminal cost and the lattice rules read it unchanged.

DECISION (docs/dynamic.md §4): within an episode, every V after the first comes from this
incremental path, never from the disk cache: the incremental V equals a full build only to the
builder's tolerance (model.md §7e.2), so mixing the two would make an episode's actions depend on
what the cache held. The first belief's V is the cached or built one (bit for bit the builder's).
"""

from __future__ import annotations

import weakref

from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.value_function import (
    LATTICE_DEFAULTS,
    LatticeSettings,
    ValueFunction,
    ValueFunctionBuilder,
    _memo,
)

_builders: weakref.WeakKeyDictionary[PenetrationModel, ValueFunctionBuilder] = weakref.WeakKeyDictionary()


def advance_value_function(
    previous: PenetrationModel, model: PenetrationModel, settings: LatticeSettings = LATTICE_DEFAULTS
) -> ValueFunction:
    """V of ``model`` (a new belief), rebuilt incrementally from ``previous``'s (one-scenario models).

    The builder of ``previous`` is kept from the last call, else built once (its V is the one
    :func:`~uav_penetration_env.value_function.value_function` gives ``previous``, bit for bit). An already advanced ``model`` returns
    its V.

    Raises:
        ValueError: a pool model (more than one scenario).
    """
    for which in (previous, model):
        if which.pool_size != 1:
            raise ValueError(f"advance_value_function: got a pool of {which.pool_size} scenarios, expected one")
    key = (0, settings)
    known = _memo.get(model, {})
    if key in known and model in _builders:
        return known[key]
    builder = _builders.get(previous)
    if builder is None or builder.settings != settings:
        # The first belief's builder; its V is value_function(previous)'s bit for bit (the cache holds
        # what this builder builds), so the planner's first steps and this rebuild agree.
        builder = ValueFunctionBuilder(previous, 0, settings)
        _builders[previous] = builder
    advanced = builder.with_model(model)
    _builders[model] = advanced
    _memo.setdefault(model, {})[key] = advanced.value_function
    return advanced.value_function
