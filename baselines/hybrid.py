"""An MPC planner warm-started by an RL agent: ``uav-bench run --policies ihpso+sb3[model=PATH.zip]``.

At every step the agent's deterministic policy is rolled forward H steps through the model from
the exact current state (``model.step`` and ``model.observe`` on a batch of one, with the
observation normalisation the agent was trained with), and that (H, 3) plan is the optimiser's
initial guess ``x0`` in place of the shifted previous plan (docs/rl-statistics.md §3).

DECISION (docs/rl-statistics.md §3): the agent's plan enters through the optimisers' one warm-start
rule, ``x0`` (optimizers.md D1), so each family uses it as it uses any warm start: the swarms
(IHPSO, HPSO, LPSO, PSO, PS2O, MCPSO, CCPSO-ISM) start particle 0 at it (MCPSO: master particle
0; PS2O: species 0, particle 0) and the other particles uniformly in the box; CEM and CMA-ES
centre their first sampling distribution on it and replace sample 0 by it; DE puts it in row 0 of
its first Latin-hypercube population. Seeding a larger share of the population around the plan
was rejected for the reason D1 gives (it biases those particles' diversity) and because it would
make the hybrid a different optimiser from the planner it is compared with. Since ``x0`` is
evaluated in the first batch and the result is the best evaluated point, the hybrid's plan is
never worse, on the window cost, than the agent's.

DECISION (docs/rl-statistics.md §3): the agent's plan *replaces* the shifted previous plan as ``x0`` (an optimiser takes one
``x0``); the previous plan's information survives only through the agent's state feedback. A
rollout that ends early (goal, crash, K_max) is padded with zero controls, as the shifted plan
is, since the window cost ignores controls after the end.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from baselines.policy import SB3Policy, load_sb3_policy
from baselines.policy_params import SB3Params, sb3_label
from uav_penetration_env.benchmark.policies import MPCPolicy
from uav_penetration_env.benchmark.policy_spec import HYBRID_SEPARATOR
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.types import FloatArray


def agent_rollout(
    agent: Any,
    model: PenetrationModel,
    state: FloatArray,
    step: int,
    observation: np.ndarray,
    horizon: int,
) -> FloatArray:
    """The agent's predicted H-step plan from ``state``: its actions along its own model rollout.

    Args:
        agent: a policy whose ``act(observation, info)`` is deterministic (an :class:`SB3Policy`).
        model: the scenario's model (a one-scenario model, as the evaluator's env uses).
        state: (6,) the exact current state.
        step: k, transitions already made.
        observation: (67,) the env's observation of ``state`` (what the agent acts on at step k).
        horizon: H.

    Returns:
        (H, 3) controls in physical units; rows after the rollout ends (goal, crash, K_max) are 0.
    """
    plan = np.zeros((horizon, 3))
    current = np.asarray(state, dtype=np.float64)[None]
    obs = np.asarray(observation)
    for j in range(horizon):
        action = np.asarray(agent.act(obs, {}), dtype=np.float64)
        plan[j] = action
        if j == horizon - 1 or step + j >= model.max_steps - 1:
            break  # the last planned control needs no successor state
        result = model.step(current, action[None], step + j)
        if result.terminated[0] or result.truncated[0]:
            break
        current = result.state
        obs = model.observe(result.state, result.step_index, result)[0]
    return plan


@dataclass
class AgentWarmStartedMPC(MPCPolicy):
    """:class:`MPCPolicy` whose optimiser starts each step from an RL agent's rollout (module docstring).

    Args:
        agent: the warm-starting agent (an :class:`SB3Policy`).
        The others: as :class:`MPCPolicy`.

    Attributes:
        last_record: as :class:`MPCPolicy`'s, plus ``agent_plan`` (the (H, 3) rollout, as a list)
            and ``agent_plan_cost`` (its window cost, the optimiser's starting point).
    """

    agent: Any = None
    _agent_plan: FloatArray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (callable(getattr(self.agent, "act", None)) and callable(getattr(self.agent, "reset", None))):
            raise TypeError(f"agent: got {self.agent!r}, expected a policy with reset(model, seed) and act")
        if not self._accepts_x0:
            raise TypeError(
                f"optimizer: {type(self.optimizer).__name__}.minimize takes no x0, so no agent can warm-start it"
            )

    def config(self) -> dict[str, Any]:
        """The planner's configuration plus the agent's (its file hashes): the store key."""
        agent = self.agent.config() if hasattr(self.agent, "config") else repr(self.agent)
        return {**super().config(), "kind": "mpc+agent", "agent": agent}

    @property
    def metadata(self) -> dict[str, Any]:
        """The agent's training budget, copied into every episode row (as for the agent itself)."""
        return dict(getattr(self.agent, "metadata", {}) or {})

    def reset(self, model: PenetrationModel, seed: int | np.random.SeedSequence | None = None) -> None:
        """Bind the model, seed the optimiser and prepare the (deterministic) agent."""
        super().reset(model, seed)
        self.agent.reset(model, None)
        self._agent_plan = None

    def initial_guess(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """The agent's H-step rollout from the exact state in ``info`` (:func:`agent_rollout`)."""
        plan = agent_rollout(
            self.agent, self.model, info["state"], int(info["step"]), observation, self.horizon
        )
        self._agent_plan = plan
        return plan

    def act(self, observation: np.ndarray, info: dict[str, Any]) -> FloatArray:
        """Plan from the agent's rollout and apply the plan's first control."""
        action = super().act(observation, info)
        plan = self._agent_plan
        cost = self.model.rollout_cost(
            np.asarray(info["state"], dtype=np.float64),
            plan[None],
            step=int(info["step"]),
            discount=self.settings.discount,
            terminal_cost=self._terminal,
        )
        self.last_record.update(agent_plan=plan.tolist(), agent_plan_cost=float(cost[0]))
        return action


def load_hybrid(agent: SB3Params, planner: MPCPolicy) -> AgentWarmStartedMPC:
    """``PLANNER+sb3[model=PATH.zip]``: ``planner`` (built by the harness) warm-started by the agent.

    Args:
        agent: the agent's parameters (as for ``sb3[...]``).
        planner: the MPC planner with its settings (horizon, budget, gamma, c_T), named by its label.

    Returns:
        The :class:`AgentWarmStartedMPC`, named ``PLANNER+sb3:STEM``.

    Raises:
        FileNotFoundError, ValueError: as :func:`baselines.policy.load_policy`.
    """
    policy: SB3Policy = load_sb3_policy(agent)
    settings = {f.name: getattr(planner, f.name) for f in dataclasses.fields(MPCPolicy) if f.init}
    for transient in ("model", "rng", "last_record", "_plan", "name"):
        settings.pop(transient, None)
    name = f"{planner.name or 'mpc'}{HYBRID_SEPARATOR}{sb3_label(agent)}"
    return AgentWarmStartedMPC(**settings, agent=policy, name=name)
