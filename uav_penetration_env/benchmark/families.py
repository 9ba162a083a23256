"""Policy families: which kind of planner a policy label names (api.md §4.1).

The figures colour and group policies by family, and the RL statistics pool RL agents and pick
the best swarm planner by it; both read it from here (no figure code is needed for a table).
"""

from __future__ import annotations

FAMILIES = (
    "paper planners (MPC)",
    "reference optimisers (MPC)",
    "IHPSO ablations (MPC)",
    "floors",
    "classical planners",
    "RL agents",
    "imitation (distilled)",
)
CLASSICAL_PLANNERS = ("lattice", "value-greedy")  # and their -cN variants (policy_names.CLEARANCE_SUFFIX)
IMITATION_KINDS = ("distill", "distill-safe", "distill-shield")  # the distilled networks' policy kinds
MPC_FAMILIES = FAMILIES[:3]  # the families whose policies are MPC planners
PAPER_PLANNERS = ("ihpso", "hpso", "lpso", "ps2o", "mcpso", "ccpso-ism")
FLOORS = ("greedy", "random")


def policy_family(label: str) -> str:
    """The family of a policy label (one of :data:`FAMILIES`).

    DECISION (api.md §4.1): a distilled network (``distill:``, ``distill-safe:``,
    ``distill-shield:``) is an imitation planner and every other plug-in policy (``PREFIX:...``,
    e.g. ``sb3:ppo``) an RL agent; ``greedy`` and ``random`` are floors; the lattice planner and
    the value-greedy rule (``lattice``, ``value-greedy`` and their ``-cN`` variants) are the
    classical planners; the paper's six swarm planners and their variants (``hpso-literal``,
    ``NAME-eq37``) are the paper planners; other ``ihpso-*`` configurations are IHPSO ablations;
    every other optimiser name (``pso``, ``cem``, ``cmaes``, ``de``, ...) is a reference optimiser.
    """
    if ":" in label:
        return "imitation (distilled)" if label.partition(":")[0] in IMITATION_KINDS else "RL agents"
    if any(label == name or _clearance_variant(label, name) for name in CLASSICAL_PLANNERS):
        return "classical planners"
    base = label.removesuffix("-eq37")
    if base in FLOORS:
        return "floors"
    if base == "ihpso":
        return "paper planners (MPC)"
    if base.startswith("ihpso-"):
        return "IHPSO ablations (MPC)"
    if any(base == name or base.startswith(f"{name}-") for name in PAPER_PLANNERS):
        return "paper planners (MPC)"
    return "reference optimisers (MPC)"


def _clearance_variant(label: str, name: str) -> bool:
    """Whether ``label`` is ``NAME-cN`` (N digits): a classical planner at another clearance."""
    digits = label.removeprefix(f"{name}-c")
    return label.startswith(f"{name}-c") and digits.isdigit()
