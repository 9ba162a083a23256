"""Checkpoints of the offline search: the optimiser's state as JSON, written atomically, and found again.

A checkpoint file ``<work>/<scenario_hash>-<mode>.json`` holds the format tag, the scenario hash,
the settings that must match to continue (:meth:`SearchSettings.key`) and the
:class:`optimizers.sep_cma_restarts.RestartState` (docs/best-known.md §1): its numbers, arrays,
generators and the running ``cmaes.SepCMA``'s attributes, each float written as its shortest
exact decimal (``repr``), so a continued search equals an uninterrupted one bit for bit.
:class:`Checkpoints` saves it every few wall seconds between generations, as the search's callback.

DECISION (docs/best-known.md §1): a checkpoint is JSON, never a pickle. A ``--work`` folder may come
from someone else ("resume this search"), and unpickling a file runs whatever code it names; a
JSON file is data, read through a fixed set of tags (arrays of plain number dtypes, tuples, the
NumPy bit generators), so a foreign file can only be refused. A ``.pkl`` checkpoint of an earlier
version is refused unread with the same one-line message.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from optimizers.sep_cma_restarts import RestartState, Start
from uav_penetration_env.atomic import write_text_atomic

CHECKPOINT_FORMAT = "uav-penetration-best-known-search/4"
MAX_CHECKPOINT_BYTES = 1 << 30  # a state of a few thousand variables takes megabytes: far below
ARRAY_DTYPES = ("<f8", "<i8", "<u4", "|b1")  # the dtypes a state holds (floats, counts, MT19937 keys)
BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")


def checkpoint_path(work: str | Path, scenario_hash: str, mode: str) -> Path:
    """The checkpoint file of one search: ``<work>/<scenario_hash>-<mode>.json``."""
    return Path(work) / f"{scenario_hash}-{mode}.json"


def _encode(value: Any) -> Any:
    """Plain JSON data of ``value``: arrays, tuples and dicts tagged so :func:`_decode` restores them exactly."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)  # json writes repr(): exact, and NaN/Infinity kept
    if isinstance(value, np.ndarray):
        array = value.astype(value.dtype.newbyteorder("<")) if value.dtype.byteorder == ">" else value
        if array.dtype.str not in ARRAY_DTYPES:
            raise TypeError(f"a checkpoint holds no {array.dtype} arrays")
        return {"ndarray": array.dtype.str, "shape": list(array.shape), "data": array.ravel().tolist()}
    if isinstance(value, tuple):
        return {"tuple": [_encode(v) for v in value]}
    if isinstance(value, list):
        return [_encode(v) for v in value]
    if isinstance(value, dict):
        return {"dict": {str(k): _encode(v) for k, v in value.items()}}
    raise TypeError(f"a checkpoint holds no {type(value).__name__}")


def _decode(value: Any) -> Any:
    """The value :func:`_encode` wrote (raises ValueError, TypeError or KeyError on anything else)."""
    if isinstance(value, list):
        return [_decode(v) for v in value]
    if not isinstance(value, dict):
        return value
    (tag,) = value if "ndarray" not in value else ("ndarray",)
    if tag == "tuple":
        return tuple(_decode(v) for v in value["tuple"])
    if tag == "dict":
        return {k: _decode(v) for k, v in value["dict"].items()}
    if tag == "ndarray" and value["ndarray"] in ARRAY_DTYPES:
        shape = tuple(int(n) for n in value["shape"])
        return np.array(value["data"], dtype=np.dtype(value["ndarray"])).reshape(shape)
    raise ValueError(f"unknown tag {tag!r}")


def state_to_json(state: RestartState) -> Any:
    """The JSON data of a search state (the running ``SepCMA`` as its attributes and its generator's state)."""
    fields = {f.name: getattr(state, f.name) for f in dataclasses.fields(RestartState)}
    fields["starts"] = [{"label": start.label, "x": np.asarray(start.x)} for start in state.starts]
    fields["rng"] = state.rng.bit_generator.state
    if state.optimizer is not None:
        fields["optimizer"] = {"attributes": state.optimizer.__getstate__(), "rng": state.optimizer._rng.get_state()}
    return _encode(fields)


def state_from_json(data: Any) -> RestartState:
    """The search state :func:`state_to_json` wrote.

    Raises:
        ValueError, TypeError, KeyError: data of any other shape.
    """
    fields = _decode(data)
    if not isinstance(fields, dict) or set(fields) != {f.name for f in dataclasses.fields(RestartState)}:
        raise ValueError("not the fields of a search state")
    fields["starts"] = [Start(str(s["label"]), np.asarray(s["x"], dtype=float)) for s in fields["starts"]]
    name = fields["rng"]["bit_generator"]
    if name not in BIT_GENERATORS:
        raise ValueError(f"unknown bit generator {name!r}")
    rng = np.random.Generator(getattr(np.random, name)())
    rng.bit_generator.state = fields["rng"]
    fields["rng"] = rng
    for name in ("lo", "hi", "best_x"):
        fields[name] = np.asarray(fields[name], dtype=float)
    if fields["optimizer"] is not None:
        from cmaes import SepCMA

        saved = fields["optimizer"]
        optimizer = SepCMA.__new__(SepCMA)
        optimizer.__setstate__(dict(saved["attributes"]))
        optimizer._rng.set_state(saved["rng"])
        fields["optimizer"] = optimizer
    fields["trace"] = [tuple(entry) for entry in fields["trace"]]
    return RestartState(**fields)


def load_checkpoint(path: Path, scenario_hash: str, key: dict[str, Any]) -> RestartState | None:
    """The search state saved in ``path``; ``None`` when there is no such file.

    The format is checked before anything else is read from the file, and nothing in it is
    executed (see the module docstring).

    Raises:
        ValueError: the file (or a pickled ``.pkl`` checkpoint of an earlier version beside it) is
            not a checkpoint of this format, or holds a search of another scenario or other settings.
    """
    refused = f"--work {path}: not a best-known search checkpoint; expected {CHECKPOINT_FORMAT}"
    pickled = path.with_suffix(".pkl")
    if pickled.exists():
        raise ValueError(
            f"--work {pickled}: not a best-known search checkpoint; expected {CHECKPOINT_FORMAT} in {path.name} "
            "(a pickled checkpoint of an earlier version is never read, since unpickling runs code: remove it)"
        )
    if not path.exists():
        return None
    try:
        if not path.is_file() or path.stat().st_size > MAX_CHECKPOINT_BYTES:
            raise ValueError(f"a regular file of at most {MAX_CHECKPOINT_BYTES} bytes")
        data = json.loads(path.read_bytes())
        if not isinstance(data, dict) or data.get("format") != CHECKPOINT_FORMAT:
            raise ValueError("no format tag")
        saved_hash, saved_key = data["scenario_hash"], data["key"]
    except (OSError, ValueError, KeyError, RecursionError) as error:
        raise ValueError(f"{refused} ({type(error).__name__}: {error})") from None
    if saved_hash != scenario_hash or saved_key != key:
        raise ValueError(
            f"--work {path}: holds a search with settings {saved_key} of scenario {saved_hash}, "
            f"expected {key} of {scenario_hash}; remove the file or choose another --work folder"
        )
    try:
        return state_from_json(data["state"])
    except (ValueError, TypeError, KeyError, AttributeError, RecursionError) as error:
        raise ValueError(f"{refused} (its state: {type(error).__name__}: {error})") from None


def save_checkpoint(path: Path, scenario_hash: str, key: dict[str, Any], state: RestartState) -> None:
    """Write the search state with what identifies its search, as JSON, atomically."""
    data = {"format": CHECKPOINT_FORMAT, "scenario_hash": scenario_hash, "key": key, "state": state_to_json(state)}
    write_text_atomic(path, json.dumps(data))


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
