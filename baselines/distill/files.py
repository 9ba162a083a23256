"""The run folder of a distillation: every file written atomically, each round's data kept.

::

    OUT/config.json                      the run's key (refused if a rerun differs)
    OUT/rounds/round-K/episode-NNNN.npz  one labelled episode (written as soon as it is flown)
    OUT/rounds/round-K.npz               the round's data: observations, expert actions, states, ...
    OUT/nets/round-K.npz, round-K.json   the network refit on rounds 0..K, and its sidecar
    OUT/policy.npz, policy.json          the last round's network: ``distill:OUT`` loads it

A round is finished when its network's sidecar exists (written last); an episode file is never
flown twice, so no expert label is computed twice, even for a round cut half-way.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from uav_penetration_env.atomic import atomic_path, write_text_atomic


def save_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write ``arrays`` to ``path`` (uncompressed ``.npz``) whole or not at all."""
    with atomic_path(path) as temporary, open(temporary, "wb") as stream:
        np.savez(stream, **arrays)


def load_npz(path: Path) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` written by :func:`save_npz` (no pickles allowed)."""
    with np.load(path, allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` as indented JSON, atomically."""
    write_text_atomic(path, json.dumps(data, indent=2, sort_keys=True) + "\n")


def sha256_file(path: Path) -> str:
    """The SHA-256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class RunFolder:
    """The paths of one run folder (see the module docstring)."""

    def __init__(self, out: str | Path) -> None:
        self.out = Path(out)

    @property
    def config(self) -> Path:
        """The run's key."""
        return self.out / "config.json"

    def episode(self, round_index: int, episode: int) -> Path:
        """One labelled episode of a round (removed once the round file holds it)."""
        return self.out / "rounds" / f"round-{round_index}" / f"episode-{episode:04d}.npz"

    def round_data(self, round_index: int) -> Path:
        """The whole data of a round."""
        return self.out / "rounds" / f"round-{round_index}.npz"

    def net(self, round_index: int) -> Path:
        """The network refit after a round."""
        return self.out / "nets" / f"round-{round_index}.npz"

    def net_sidecar(self, round_index: int) -> Path:
        """Its sidecar (written last: the round is finished)."""
        return self.net(round_index).with_suffix(".json")

    @property
    def policy(self) -> Path:
        """The final network."""
        return self.out / "policy.npz"

    @property
    def policy_sidecar(self) -> Path:
        """The final network's sidecar."""
        return self.out / "policy.json"

    def finished_rounds(self) -> int:
        """How many rounds (0, 1, ...) in a row have a network sidecar."""
        count = 0
        while self.net_sidecar(count).is_file():
            count += 1
        return count
