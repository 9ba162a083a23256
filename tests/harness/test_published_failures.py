"""The published paper-scenario failures of leaderboard v2, re-flown from their goal-pass states (model.md §7e).

Eleven MPC episodes of the committed v2 rows fail on the paper scenario, all IHPSO variants; none
crashes on the way in: each passes the goal at 6-17 km and crashes later. The goal-pass decision
state of each is the state four steps (12 km of flight) before its closest approach, where every
one still had the goal ahead (heading error 7-57 degrees, 14-23 km out) and turned away under the
straight-line cost-to-go. From there the default planner (the lattice value function as terminal
cost) must reach the goal.

From the closest approach itself (the goal inside the turning circle, pointing 74-94 degrees away,
the map corner 15-25 km ahead) a loop is the only way back, and the default IHPSO flies it in 6 of
the 11 (model.md §7e.4); that is not asserted here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from uav_penetration_env import paper_scenario
from uav_penetration_env.benchmark.policies import make_policy
from uav_penetration_env.model import PenetrationModel

ROWS = Path(__file__).resolve().parents[2] / "leaderboards" / "rows"


STEPS_BEFORE_CLOSEST = 4


def published_failure_states() -> list[tuple[str, int, int, np.ndarray]]:
    """(policy, seed, step, state (6,)) at the goal-pass decision state of every failed v2 MPC paper episode."""
    episodes = pd.read_parquet(
        ROWS / "leaderboard-episodes.parquet", columns=["episode_id", "policy", "scenario", "seed", "outcome"]
    )
    failed = episodes[
        (episodes.scenario == "paper-2022-sec5")
        & (episodes.outcome != "success")
        & ~episodes.policy.str.startswith("sb3:")
        & ~episodes.policy.isin(["greedy", "random"])
    ]
    steps = pd.read_parquet(
        ROWS / "leaderboard-steps.parquet",
        columns=["episode_id", "step", "x_km", "y_km", "z_m", "speed", "heading", "pitch", "distance_to_goal"],
        filters=[("episode_id", "in", failed.episode_id.tolist())],
    )
    out = []
    for row in failed.itertuples():
        track = steps[steps.episode_id == row.episode_id].set_index("step")
        closest = track.loc[track.distance_to_goal.idxmin() - STEPS_BEFORE_CLOSEST]
        state = np.array(
            [closest.x_km * 1000.0, closest.y_km * 1000.0, closest.z_m, closest.speed, closest.heading, closest.pitch]
        )
        out.append((row.policy, int(row.seed), int(closest.name), state))
    return out


FAILURES = published_failure_states()


def fly_from(model: PenetrationModel, policy, state: np.ndarray, step: int) -> tuple[str, float]:
    """Fly ``policy`` from ``state`` at ``step`` to the episode's end: (outcome, closest approach [km])."""
    closest = np.inf
    for k in range(step, model.max_steps):
        action = policy.act(None, {"state": state, "step": k})
        result = model.step(state[None], action[None], k)
        state = result.state[0]
        closest = min(closest, float(result.goal_distance[0]) / 1000.0)
        if result.reached_goal[0]:
            return "success", closest
        if result.terminated[0]:
            return ("collided" if result.collided[0] else "out_of_area"), closest
    return "truncated", closest


def test_the_rows_hold_the_eleven_published_failures():
    assert len(FAILURES) == 11
    assert {policy.split("-")[0] for policy, *_ in FAILURES} == {"ihpso"}


@pytest.fixture(scope="module")
def model():
    return PenetrationModel(paper_scenario())


@pytest.mark.parametrize("case", range(len(FAILURES)))
def test_the_lattice_planner_reaches_the_goal_from_each_decision_state(model, case):
    _, _, step, state = FAILURES[case]
    policy = make_policy("lattice")
    policy.reset(model, 0)
    assert fly_from(model, policy, state, step)[0] == "success"


def test_the_default_ihpso_reaches_the_goal_from_the_seed_0_decision_state(model):
    """A fast smoke test of the slow one below: seed 0's state, a tenth of the budget."""
    ((_, _, step, state),) = [f for f in FAILURES if f[:2] == ("ihpso", 0)]
    policy = make_policy("ihpso", max_evals=1000)
    policy.reset(model, 0)
    assert fly_from(model, policy, state, step)[0] == "success"


# Known defect, tracked: from ihpso-2022v0 seed 11's decision state (12.8 km out, 48 degrees off,
# the goal already inside the turning circle) HPSO's loop drifts north into the band where the
# edge-doomed nodes of V begin, and it crashes at the north edge; 4 of 6 other policy seeds reach
# the goal. V prices the loop at 6.1 there and the band ahead only one window later (model.md §7e.4).
KNOWN = {
    ("ihpso-2022v0", 11, "hpso"): "HPSO's loop from ihpso-2022v0 seed 11's state runs into the north edge (model.md §7e.4)"
}


def _case(case: int, planner: str):
    policy, seed, _, _ = FAILURES[case]
    reason = KNOWN.get((policy, seed, planner))
    # Not strict: a chaotic closed-loop flight may succeed on another machine's last digits.
    return pytest.param(case, planner, marks=pytest.mark.xfail(strict=False, reason=reason)) if reason else (case, planner)


@pytest.mark.slow
@pytest.mark.parametrize(("case", "planner"), [_case(c, p) for p in ("ihpso", "hpso") for c in range(len(FAILURES))])
def test_the_default_planners_reach_the_goal_from_each_decision_state(model, planner, case):
    _, seed, step, state = FAILURES[case]
    policy = make_policy(planner)
    policy.reset(model, seed)
    assert fly_from(model, policy, state, step)[0] == "success"
