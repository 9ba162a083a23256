"""The grammar of policy names (``uav-bench run --policies``), without the policies' code.

:func:`~uav_penetration_env.benchmark.policies.make_policy` builds a policy from its name; this
module only knows which names exist, so ``uav-bench run`` refuses a mistyped one before it imports
the physics and the compiled code (a second, not the ten of the first episode's imports;
api.md §4.7). It imports no numba-compiled module: the optimiser registry (numpy, scipy) and the
plug-in entry points only.
"""

from __future__ import annotations

from collections.abc import Sequence

from uav_penetration_env.benchmark.plugins import (
    HYBRID_SEPARATOR,
    POLICY_GROUP,
    plugin_policy_forms,
    policy_kinds,
)
from uav_penetration_env.suggest import did_you_mean

FLOOR_NAMES = ("greedy", "random")  # policies.FLOOR_POLICIES
BASELINE_NAMES = ("lattice", "value-greedy")  # policies.BASELINE_POLICIES: the classical global planner
CLEARANCE_SUFFIX = "-c"  # lattice-cN, value-greedy-cN: the rule following the terrain at N metres
CLEARANCES_M = (10, 1000)  # the N a -cN name accepts
EQ37_SUFFIX = "-eq37"
# An MPC planner's name with one of these suffixes fixes its terminal cost's form (model.md §7e).
TERMINAL_SUFFIXES = {
    EQ37_SUFFIX: "none",
    "-ctg-distance": "distance",
    "-ctg-dubins": "dubins",
    "-ctg-value": "value",
}


def split_terminal(spec: str, names: Sequence[str]) -> tuple[str, str | None]:
    """``NAME-SUFFIX`` -> (``NAME``, its terminal form); a plain or unknown name -> (spec, None)."""
    if spec in names:
        return spec, None
    for suffix, form in TERMINAL_SUFFIXES.items():
        if spec.endswith(suffix) and spec[: -len(suffix)] in names:
            return spec[: -len(suffix)], form
    return spec, None


def split_hybrid(spec: str) -> tuple[str, str] | None:
    """``(planner, plug-in spec)`` of a hybrid name ``PLANNER+PREFIX:ARGUMENT``, else None.

    The planner is an optimiser name or ``NAME-eq37``; the part after ``+`` is a plug-in policy
    (``ihpso+sb3:models/ppo.zip`` -> ``("ihpso", "sb3:models/ppo.zip")``). Only the text before the
    first colon is searched for ``+``, so a path may contain one.
    """
    prefix, colon, _ = spec.partition(":")
    planner, plus, kind = prefix.partition(HYBRID_SEPARATOR)
    if not (colon and plus and planner and kind):
        return None
    return planner, spec[len(planner) + len(HYBRID_SEPARATOR) :]


def policy_names() -> list[str]:
    """Every plain name :func:`~uav_penetration_env.benchmark.policies.make_policy` accepts (plug-in kinds aside)."""
    from optimizers import available_optimizers

    names = available_optimizers()
    suffixed = [f"{n}{suffix}" for n in names for suffix in TERMINAL_SUFFIXES]
    return sorted([*FLOOR_NAMES, *BASELINE_NAMES, *names, *suffixed])


def unknown_policy(spec: str) -> str | None:
    """The error of a name no policy has (with suggestions and the known forms), else None.

    A name of a known form passes (``lattice-cN``, a hybrid, ``PREFIX:ARGUMENT`` of an installed
    kind): its argument (N, the plug-in's file) is checked when the policy is built.
    """
    from optimizers import available_optimizers

    if spec in FLOOR_NAMES or spec in BASELINE_NAMES or split_hybrid(spec) is not None:
        return None
    base, suffix, _ = spec.rpartition(CLEARANCE_SUFFIX)
    if suffix and base in BASELINE_NAMES:
        return None
    prefix, colon, _ = spec.partition(":")
    kinds = policy_kinds() if colon else {}
    if prefix in kinds:
        return None
    names = available_optimizers()
    if split_terminal(spec, names)[0] in names:
        return None
    # A prefix is compared with the plug-in prefixes, a plain name with the plain names.
    hint = did_you_mean(prefix, kinds) if colon else did_you_mean(spec, policy_names())
    if colon:  # name the mechanism: the kind may belong to a package that is not installed
        hint = f"no installed plug-in provides the kind {prefix!r} (entry points {POLICY_GROUP}); {hint}"
    known = ", ".join(["greedy", "random", "lattice", "lattice-cN", "value-greedy", "value-greedy-cN", "NAME-eq37",
                       "NAME-ctg-FORM", *plugin_policy_forms()])  # fmt: skip
    return f"unknown policy {spec!r} — {hint}known: {known} and the optimisers {', '.join(names)}"
