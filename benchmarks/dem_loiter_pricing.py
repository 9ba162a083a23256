"""Why the v2 MPC planners loitered on the DEM member: re-price their loiter windows (model.md §7e.4).

For four failed leaderboard-v2 episodes on ``dem-topobathy`` it takes the exact state at steps 60
and 100 from the committed rows and prices two 5-step windows from there under the ``distance``
and the ``value`` terminal forms: the actions the planner flew next, and the lattice planner's
window toward the goal. Prints one line per state.

Usage:
    python benchmarks/dem_loiter_pricing.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from uav_penetration_env.catalogue import resolve_scenario
from uav_penetration_env.model import PenetrationModel
from uav_penetration_env.mpc import Terminal
from uav_penetration_env.terminal import terminal_cost
from uav_penetration_env.value_function import lattice_action, value_function

ROWS = Path(__file__).resolve().parents[1] / "leaderboards" / "rows"
EPISODES = (("ihpso", 0), ("hpso", 1), ("lpso", 1), ("ps2o", 0))
STEPS = (60, 100)
HORIZON = 5


def main() -> int:
    episodes = pd.read_parquet(ROWS / "leaderboard-episodes.parquet", columns=["episode_id", "policy", "scenario", "seed"])
    model = PenetrationModel(resolve_scenario("dem"))
    vf = value_function(model)
    action_columns = ["action_dv", "action_dphi", "action_dtheta"]
    for policy, seed in EPISODES:
        chosen = episodes[(episodes.scenario == "dem-topobathy") & (episodes.policy == policy) & (episodes.seed == seed)]
        steps = pd.read_parquet(ROWS / "leaderboard-steps.parquet", filters=[("episode_id", "in", [int(chosen.episode_id.iloc[0])])])
        steps = steps.set_index("step")
        for k in STEPS:
            row = steps.loc[k]
            state = np.array([row.x_km * 1e3, row.y_km * 1e3, row.z_m, row.speed, row.heading, row.pitch])
            flown = steps.loc[k + 1 : k + HORIZON, action_columns].to_numpy()
            toward, x = [], state.copy()
            for j in range(HORIZON):
                action = lattice_action(model, vf, x, k + j)
                toward.append(action)
                x = model.step(x[None], action[None], k + j).state[0]
            plans = np.stack([flown, np.array(toward)])
            line = [f"{policy} seed {seed} step {k}: {row.distance_to_goal:.1f} km out at {row.speed:.1f} m/s"]
            for form in ("distance", "value"):
                cost = model.rollout_cost(state, plans, step=k, terminal_cost=terminal_cost(model, Terminal(form)))
                line.append(f"{form}: flown {cost[0]:.2f}, toward the goal {cost[1]:.2f}")
            print(" | ".join(line))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
