"""Scenario YAML files on disk: read and write plain data, file problems as :class:`ScenarioError`.

Both functions report a problem with the file itself on the field ``path`` (the file's name as the
value), so a missing, unreadable, unwritable or malformed file reads like any other bad field.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from uav_penetration_env.atomic import NotRegularFileError, write_text_atomic
from uav_penetration_env.scenario.errors import ScenarioError

__all__ = ["load_yaml_text", "read_yaml", "write_yaml"]

# Limits far above any real scenario (the paper's file: depth 6, about 300 nodes) and far below what
# hangs or exhausts the loader: hostile YAML (an alias bomb, thousands of nested brackets) gets an
# error in milliseconds instead of minutes, or a RecursionError.
MAX_DEPTH = 64
MAX_NODES = 200_000  # counted with every alias expanded


class StrictLoader(yaml.SafeLoader):
    """PyYAML's safe loader that refuses duplicate keys and nesting deeper than :data:`MAX_DEPTH`.

    PyYAML keeps the last of two equal keys without a word; for a configuration that silently drops
    what the user wrote (a first ``time:`` block), so here it is an error naming the key and line.
    """

    depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self.depth += 1
        try:
            if self.depth > MAX_DEPTH:
                mark = self.peek_event().start_mark
                raise yaml.composer.ComposerError(None, None, f"nested deeper than {MAX_DEPTH} levels", mark)
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue  # a merge (<<) may be overridden by the mapping's own keys, as YAML says
                key = self.construct_object(key_node, deep=True)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"a key that is not a plain value ({type(key).__name__})", key_node.start_mark
                    ) from None
                if duplicate:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate key {key!r} (each key may appear once)", key_node.start_mark
                    )
        return super().construct_mapping(node, deep)


def _expanded_size(node: Any, memo: dict[int, int]) -> int:
    """Nodes under ``node`` with every alias expanded (memoised: an alias bomb is counted, not built)."""
    known = memo.get(id(node))
    if known is not None:
        return known
    memo[id(node)] = 1  # a cycle counts once (PyYAML refuses recursive aliases in safe loading anyway)
    children = node.value if isinstance(node.value, list) else []
    size = 1
    for child in children:
        size += sum(_expanded_size(n, memo) for n in child) if isinstance(child, tuple) else _expanded_size(child, memo)
        if size > MAX_NODES:
            break
    memo[id(node)] = size
    return size


def load_yaml_text(text: str, where: str) -> Any:
    """The plain data of YAML ``text``, strictly: no duplicate keys, bounded depth and expanded size.

    Raises:
        ScenarioError: on the field ``path`` (value ``where``): not valid YAML, a duplicate key, or
            beyond the limits.
    """
    loader = StrictLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        size = _expanded_size(node, {})
        if size > MAX_NODES:
            raise ScenarioError("path", where, f"at most {MAX_NODES:,} YAML nodes with aliases expanded (an alias bomb?)")
        return loader.construct_document(node)
    except yaml.YAMLError as error:
        raise ScenarioError("path", where, f"valid YAML ({_one_line(error)})") from None
    finally:
        loader.dispose()


def _one_line(error: yaml.YAMLError) -> str:
    """PyYAML's message on one line, without the quoted source excerpt."""
    problem = getattr(error, "problem", None)
    mark = getattr(error, "problem_mark", None)
    if problem is None:
        return " ".join(str(error).split())[:300]
    return f"{problem} at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else str(problem)


def read_yaml(path: Path) -> Any:
    """The plain data of the YAML file ``path`` (``None`` for an empty file).

    Raises:
        ScenarioError: the file is missing, unreadable or not UTF-8, or is not valid YAML in the
            strict sense of :func:`load_yaml_text` (no duplicate keys, bounded depth and size).
    """
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ScenarioError("path", str(path), f"a readable scenario file ({error.strerror})") from error
    except UnicodeDecodeError as error:
        raise ScenarioError("path", str(path), f"a UTF-8 text file (byte {error.start} is not UTF-8)") from None
    return load_yaml_text(text, str(path))


def write_yaml(data: Any, path: Path) -> Path:
    """Write plain ``data`` to ``path`` as YAML, keys in their given order (lists of scalars inline); returns ``path``.

    Raises:
        NotRegularFileError: ``path`` is a device, a FIFO or a folder (the caller names its flag).
        ScenarioError: the path (or its folder) cannot be written.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(path, yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=110))
    except NotRegularFileError:
        raise  # a device or FIFO in the way: the caller names the flag that chose the path
    except OSError as error:
        raise ScenarioError("path", str(path), f"a writable file path ({error.strerror})") from error
    return path
