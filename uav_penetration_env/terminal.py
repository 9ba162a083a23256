"""The terminal cost of MPC windows: from its setting to what the rollout kernel reads (model.md §7e).

Eq. 37 prices only the H steps of a window. A receding-horizon planner needs a price for where a
window leaves the UAV, or it defers threat past the horizon: a window that ends pointing away from
the goal, or with the goal inside the turning circle, looks as cheap as one lined up for it. That
price is the **terminal cost**, one concept under one name: its setting is a
:class:`~uav_penetration_env.mpc.Terminal` (a form and a scale c_T, the one field
``MPCSettings.terminal``; flags ``--terminal`` and ``--terminal-cost``), and
:func:`terminal_cost` builds it on a scenario's model into the
:class:`~uav_penetration_env.terminal_kernels.TerminalCost` that ``PenetrationModel.rollout_cost`` takes
(and nothing else: a bare number is refused). The forms:

========  ==================================================================================
form      terminal cost of an end state (x, y, psi) still flying before K_max
========  ==================================================================================
none      0 (the paper's literal eq. 37; the ``NAME-eq37`` planners)
distance  c_T d_goal / (v_max dt): the straight-line steps left, c_T each (default 0.06)
dubins    c_T L_dubins / (v_max dt): the steps of the shortest forward path at the turning
          radius v_max dt / dphi_max (default c_T: the scenario's calibrated J per step)
value     V(x, y, psi): the lattice value function (:mod:`uav_penetration_env.value_function`)
========  ==================================================================================

The compiled scalar functions that evaluate a built terminal cost inside the rollout kernel
(``terminal_value``, ``dubins_length``, ``value_lookup``) are in :mod:`uav_penetration_env.terminal_kernels`,
below the model, which the kernels import; this module sits above the value function it reads.
"""

from __future__ import annotations

import math

import numpy as np

from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.mpc import SCALED_FORMS, Terminal
from uav_penetration_env.terminal_kernels import G_STEP_LENGTH, G_TURN_RADIUS, N_GRID, TerminalCost
from uav_penetration_env.types import TERMINAL_FORMS
from uav_penetration_env.value_function import value_function

DISTANCE_COST_PER_STEP = 0.06  # c_T of the straight-line form (the project's first terminal cost, model.md §7e)


def terminal_cost(model: PenetrationModel, terminal: Terminal, scenario_index: int = 0) -> TerminalCost:
    """The terminal cost ``terminal`` built on one pool member of ``model``, as ``rollout_cost`` reads it.

    Args:
        model: the scenario's model.
        terminal: the form and c_T; c_T None takes the form's default (``distance``:
            :data:`DISTANCE_COST_PER_STEP`; ``dubins``: the scenario's calibrated J per step,
            ``ValueFunction.route_j_per_step``); ``none`` and ``value`` read no c_T.
        scenario_index: the pool member (its value function, for ``value`` and ``dubins``).

    Raises:
        TypeError: ``terminal`` not a :class:`~uav_penetration_env.mpc.Terminal`.
    """
    if not isinstance(terminal, Terminal):
        raise TypeError(f"terminal: got {terminal!r}, expected a Terminal(form, scale) (uav_penetration_env.mpc)")
    form = terminal.form
    if form in ("none", "distance"):
        limits = model.limits
        scale = 0.0 if form == "none" else float(_or(terminal.scale, DISTANCE_COST_PER_STEP))
        return _analytic(form, scale, limits.max_step_length, limits.max_step_length / limits.dheading_max)
    values = value_function(model, scenario_index)
    if form == "value":
        return TerminalCost(TERMINAL_FORMS["value"], 1.0, values.table, values.grid)
    scale = float(_or(terminal.scale, values.route_j_per_step))
    return _analytic(form, scale, values.grid[G_STEP_LENGTH], values.grid[G_TURN_RADIUS])


def _or(scale: float | None, default: float) -> float:
    """``scale``, or ``default`` where it is None (the form's default c_T)."""
    return default if scale is None else scale


def _analytic(form: str, scale: float, step_length: float, turn_radius: float) -> TerminalCost:
    """A ``none``, ``distance`` or ``dubins`` terminal cost (no value table).

    Args:
        form: ``none``, ``distance`` or ``dubins``.
        scale: c_T >= 0 [J per step at v_max]; 0 gives the ``none`` form's code.
        step_length: v_max dt [m].
        turn_radius: v_max dt / dphi_max [m].
    """
    if not (form == "none" or form in SCALED_FORMS) or not (math.isfinite(scale) and scale >= 0.0):
        raise ValueError(f"terminal: got {form!r} with c_T {scale!r}, expected none, distance or dubins, c_T >= 0")
    grid = np.zeros(N_GRID)
    grid[G_STEP_LENGTH] = step_length
    grid[G_TURN_RADIUS] = turn_radius
    kind = TERMINAL_FORMS[form] if scale > 0.0 else 0
    return TerminalCost(kind, float(scale), np.zeros((1, 1, 1)), grid)


__all__ = ["DISTANCE_COST_PER_STEP", "Terminal", "TerminalCost", "terminal_cost"]
