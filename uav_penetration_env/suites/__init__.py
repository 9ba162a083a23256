"""Frozen, named benchmark suites: members, fingerprints and the guard that refuses a changed member.

A suite (docs/suite.md) is a YAML file shipped beside this package (``uavpen-v1.yaml``): a name,
a description and its members, each with how it is built and a fingerprint frozen when the file
was written. Rebuilding a member checks it against that fingerprint and refuses a change; a change
needs a new suite version (``uav-bench suite freeze``), and old versions stay as they are.

The package is split by job; every public name is importable from here:

* :mod:`.schema`: the file's content as objects (:class:`Recipe`, :class:`SuiteMember`,
  :class:`Suite`), parsed and validated from dicts;
* :mod:`.fingerprint`: computing a member's fingerprint from its replay controls, and the guard
  (:func:`check_fingerprint`), which replays the stored controls open loop;
* :mod:`.loading`: the shipped files, and building members guarded (:func:`build_member`);
* :mod:`.seeds`: the default episode seeds of a suite run (:func:`default_seeds`);
* :mod:`.freeze`: writing a new version's file (:func:`write_suite`); choosing the members' replay
  controls and freezing a new version is the harness's
  (:func:`uav_penetration_env.benchmark.suite_freeze.freeze_suite`).
"""

from __future__ import annotations

from uav_penetration_env.suites.fingerprint import (
    FINGERPRINT_FIELDS,
    QUANTUM_M,
    REPLAY_SEED,
    TOTAL_J_RTOL,
    SuiteMismatchError,
    array_hash,
    check_fingerprint,
    fingerprint,
    fingerprint_rules,
    replay_episode,
    replay_total_j,
)
from uav_penetration_env.suites.freeze import (
    frozen_provenance,
    new_suite_path,
    recipes_from_dict,
    suite_text,
    write_suite,
)
from uav_penetration_env.suites.loading import (
    SUITE_FOLDER,
    SUITE_SUFFIX,
    MemberCheck,
    build_member,
    load_suite,
    suite_names,
    suite_path,
    suite_scenarios,
    verify_suite,
)
from uav_penetration_env.suites.schema import (
    ACTIONS_ENCODING,
    DIFFICULTY_GROUPS,
    FINGERPRINT_SCHEME,
    FIXED_GROUP,
    MEMBER_KEYS,
    SUITE_KEYS,
    Fingerprint,
    Recipe,
    Suite,
    SuiteError,
    SuiteMember,
    as_controls,
    decode_actions,
    encode_actions,
    suite_from_dict,
)
from uav_penetration_env.suites.seeds import (
    FIXED_MEMBER_SEEDS,
    PROCEDURAL_MEMBER_SEEDS,
    default_seeds,
    random_start,
)

__all__ = [
    "ACTIONS_ENCODING",
    "DIFFICULTY_GROUPS",
    "FINGERPRINT_FIELDS",
    "FINGERPRINT_SCHEME",
    "FIXED_GROUP",
    "FIXED_MEMBER_SEEDS",
    "MEMBER_KEYS",
    "PROCEDURAL_MEMBER_SEEDS",
    "QUANTUM_M",
    "REPLAY_SEED",
    "SUITE_FOLDER",
    "SUITE_KEYS",
    "SUITE_SUFFIX",
    "TOTAL_J_RTOL",
    "Fingerprint",
    "MemberCheck",
    "Recipe",
    "Suite",
    "SuiteError",
    "SuiteMember",
    "SuiteMismatchError",
    "array_hash",
    "as_controls",
    "build_member",
    "check_fingerprint",
    "decode_actions",
    "default_seeds",
    "encode_actions",
    "fingerprint",
    "fingerprint_rules",
    "frozen_provenance",
    "load_suite",
    "new_suite_path",
    "random_start",
    "recipes_from_dict",
    "replay_episode",
    "replay_total_j",
    "suite_from_dict",
    "suite_names",
    "suite_path",
    "suite_scenarios",
    "suite_text",
    "verify_suite",
    "write_suite",
]
