"""A distilled network's ``policy.npz`` checked from its headers before any array is read (docs/rl.md §4.3).

A network folder may come from someone else. Its ``.npz`` is a zip of ``.npy`` members, and each
member's header declares its dtype and shape; NumPy reads (and decompresses) a member to the size
its header declares, so a 16 MB file can declare a 16 GiB array. Here only the headers are read,
the first bytes of each member, and every member must fit the network its sidecar describes
(``input_size``, ``hidden``): at most two dimensions, none wider than the widest layer, a real
float dtype (the ``features`` names as text), and an uncompressed size that matches its header.
DECISION (docs/rl.md §4.3): the sidecar bounds the sizes, and an absolute bound
(:data:`MAX_WIDTH`) bounds the sidecar, so neither file alone can make the loader allocate more
than a few hundred megabytes.
"""

from __future__ import annotations

import math
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

MAX_WIDTH = 8192  # widest layer a sidecar may declare: 8192 x 8192 float64 is 512 MiB
MAX_OUTPUTS = 64  # the heads' outputs: 3 controls, 5 turns, ...
MAX_MEMBERS = 256
MAX_FEATURE_NAMES = 64
HEADER_SLACK = 4096  # magic, header and its padding, beyond the array's own bytes


def _refuse(path: Path, what: str) -> ValueError:
    return ValueError(f"{path}: {what}; expected the network its sidecar describes (distill:PATH, rl.md §4)")


def widest_layer(sidecar: Mapping[str, Any], observation_size: int) -> int:
    """The widest dimension any array of the network may have, from its sidecar.

    Raises:
        ValueError: a sidecar whose ``input_size`` or ``hidden`` are not integers in [1, MAX_WIDTH].
    """
    widths = [sidecar.get("input_size", observation_size), *sidecar.get("hidden", [])]
    if not all(isinstance(w, int) and not isinstance(w, bool) and 1 <= w <= MAX_WIDTH for w in widths):
        raise ValueError(
            f"sidecar: input_size and hidden got {widths!r}, expected integers in [1, {MAX_WIDTH}]"
        )
    return max(*widths, observation_size, MAX_OUTPUTS)


def _header(stream: Any) -> tuple[tuple[int, ...], np.dtype]:
    """(shape, dtype) of a ``.npy`` stream, reading its header only."""
    version = np.lib.format.read_magic(stream)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(stream)
    elif version == (2, 0):
        shape, _, dtype = np.lib.format.read_array_header_2_0(stream)
    else:
        raise ValueError(f"an .npy format version {version}")
    return tuple(shape), dtype


def check_weights(path: Path, sidecar: Mapping[str, Any], observation_size: int) -> None:
    """Refuse ``path`` unless every member fits the network ``sidecar`` describes (module docstring).

    Reads the zip directory and each member's header; no array is read or decompressed whole.

    Raises:
        ValueError: one line naming the file, the member and what it declares.
    """
    widest = widest_layer(sidecar, observation_size)
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
            if len(members) > MAX_MEMBERS:
                raise _refuse(path, f"{len(members)} members")
            for info in members:
                name = info.filename.removesuffix(".npy")
                with archive.open(info) as stream:
                    shape, dtype = _header(stream)
                _check_member(path, name, shape, dtype, widest, info.file_size)
    except (zipfile.BadZipFile, OSError, ValueError, SyntaxError, EOFError) as error:
        if isinstance(error, ValueError) and str(error).startswith(f"{path}:"):
            raise
        raise _refuse(path, f"not a readable .npz of arrays ({type(error).__name__}: {error})") from None


def _check_member(
    path: Path, name: str, shape: tuple[int, ...], dtype: np.dtype, widest: int, stored_size: int
) -> None:
    if name == "features":  # the feature sets' names: a short vector of text
        if dtype.kind != "U" or len(shape) > 1 or math.prod(shape) > MAX_FEATURE_NAMES or dtype.itemsize > 1024:
            raise _refuse(path, f"member {name!r} declares {dtype} {shape}, not a short vector of names")
    elif dtype.kind != "f" or dtype.itemsize > 8:
        raise _refuse(path, f"member {name!r} declares dtype {dtype}, not real floating point numbers")
    if len(shape) > 2 or any(n > widest for n in shape):
        raise _refuse(
            path,
            f"member {name!r} declares shape {shape}, beyond the sizes its sidecar declares (at most 2 "
            f"dimensions of at most {widest})",
        )
    if stored_size > math.prod(shape) * dtype.itemsize + HEADER_SLACK:
        raise _refuse(path, f"member {name!r} holds {stored_size} bytes, more than its header declares")


__all__ = ["MAX_WIDTH", "check_weights", "widest_layer"]
