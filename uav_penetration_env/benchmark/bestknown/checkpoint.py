"""Checkpoints of the offline search: the optimiser's state pickled atomically, and found again.

A checkpoint file ``<work>/<scenario_hash>-<mode>.pkl`` holds the format tag, the scenario hash,
the settings that must match to continue (:meth:`SearchSettings.key`) and the
:class:`optimizers.sep_cma_restarts.RestartState`, which pickles exactly (docs/best-known.md §1).
:class:`Checkpoints` saves it every few wall seconds between generations, as the search's callback.
"""

from __future__ import annotations

import pickle
import time
from pathlib import Path
from typing import Any

from optimizers.sep_cma_restarts import RestartState
from uav_penetration_env.atomic import write_bytes_atomic

CHECKPOINT_FORMAT = "uav-penetration-best-known-search/3"


def checkpoint_path(work: str | Path, scenario_hash: str, mode: str) -> Path:
    """The checkpoint file of one search: ``<work>/<scenario_hash>-<mode>.pkl``."""
    return Path(work) / f"{scenario_hash}-{mode}.pkl"


def load_checkpoint(path: Path, scenario_hash: str, key: dict[str, Any]) -> RestartState | None:
    """The search state saved in ``path``; ``None`` when there is no such file.

    Raises:
        ValueError: the file is not a checkpoint of this format, or holds a search of another
            scenario or other settings.
    """
    if not path.is_file():
        return None
    refused = f"--work {path}: not a best-known search checkpoint; expected {CHECKPOINT_FORMAT}"
    try:
        with path.open("rb") as handle:
            data = pickle.load(handle)
    except (pickle.UnpicklingError, EOFError, AttributeError, ImportError, TypeError) as error:
        raise ValueError(f"{refused} ({type(error).__name__}: {error})") from None
    if not isinstance(data, dict) or data.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(refused)
    if data["scenario_hash"] != scenario_hash or data["key"] != key:
        raise ValueError(
            f"--work {path}: holds a search with settings {data['key']} of scenario {data['scenario_hash']}, "
            f"expected {key} of {scenario_hash}; remove the file or choose another --work folder"
        )
    return data["state"]


def save_checkpoint(path: Path, scenario_hash: str, key: dict[str, Any], state: RestartState) -> None:
    """Pickle the search state with what identifies its search, atomically."""
    data = {"format": CHECKPOINT_FORMAT, "scenario_hash": scenario_hash, "key": key, "state": state}
    write_bytes_atomic(path, pickle.dumps(data))


class Checkpoints:
    """Saves a search's state to one file at most every ``every`` wall seconds (and when asked).

    Args:
        path: the checkpoint file (``None``: nothing is ever saved).
        scenario_hash: the scenario of the search.
        key: the settings a continuation must share.
        every: wall seconds between two saves by :meth:`maybe_save`.
    """

    def __init__(self, path: Path | None, scenario_hash: str, key: dict[str, Any], every: float) -> None:
        self.path = path
        self.scenario_hash = scenario_hash
        self.key = key
        self.every = every
        self.last = time.perf_counter()

    def load(self) -> RestartState | None:
        """The saved state, or ``None`` when there is no file (or no path); see :func:`load_checkpoint`."""
        return None if self.path is None else load_checkpoint(self.path, self.scenario_hash, self.key)

    def save(self, state: RestartState) -> None:
        """Save ``state`` now."""
        if self.path is not None:
            save_checkpoint(self.path, self.scenario_hash, self.key, state)
        self.last = time.perf_counter()

    def maybe_save(self, state: RestartState) -> None:
        """Save ``state`` when ``every`` seconds have passed since the last save."""
        if self.path is not None and time.perf_counter() - self.last >= self.every:
            self.save(state)
