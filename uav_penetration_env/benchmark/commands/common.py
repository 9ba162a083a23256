"""What every ``uav-bench`` command shares: the command objects, errors, argument grammar, store flags.

A command is a :class:`Command` (name, help, ``add_arguments(parser)``, ``run(args) -> int``);
a :class:`CommandExtension` adds flags to an existing command and takes the invocations that
use them (``plot --models``). Built-in commands are listed in
:data:`uav_penetration_env.benchmark.commands.BUILTIN_COMMANDS`; plug-ins declare theirs under
the entry-point group ``uav_penetration.commands`` (:mod:`uav_penetration_env.benchmark.plugins`).

Every input is checked before anything is written: problems raise :class:`CLIError`, which
``uav-bench`` prints as one line ``uav-bench: error: ...`` with exit status 2.
"""

from __future__ import annotations

import argparse
import contextlib
import shlex
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uav_penetration_env.benchmark.plugins import Needs

if TYPE_CHECKING:  # the store module imports pandas: loaded by the commands that need it
    from uav_penetration_env.benchmark.store import StoreError

# What the harness imports beyond the core (the `harness` extra of pyproject.toml): a core-only
# install (the env alone) gets one line naming the extra instead of a traceback from pandas.
HARNESS = Needs(
    modules=("pandas", "pyarrow", "matplotlib", "joblib", "plotly", "rich"),
    install="the harness extra: pip install -e '.[harness]' in a checkout, or pip install 'uav-penetration[harness]'",
)

DEFAULT_STORE = Path("results/uav-bench.sqlite")
DEFAULT_OUT = Path("results")


class CLIError(Exception):
    """A user input problem: printed as ``uav-bench: error: ...`` with exit status 2."""


@dataclass(frozen=True)
class Command:
    """One ``uav-bench`` sub-command.

    Attributes:
        name: the sub-command (``run``).
        help: one line for ``uav-bench --help``.
        add_arguments: adds the command's flags to its sub-parser.
        run: does the work; returns the exit status; raises :class:`CLIError` for bad input.
        needs: modules the command needs at run time (checked after parsing, before ``run``);
            by default the harness extra's (:data:`HARNESS`).
    """

    name: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    needs: Needs = HARNESS


@dataclass(frozen=True)
class CommandExtension:
    """Flags a plug-in adds to an existing command, and the invocations it takes over.

    Attributes:
        command: the name of the extended command (``plot``).
        add_arguments: adds the extension's flags to that command's sub-parser.
        selected: whether a parsed invocation is the extension's (e.g. ``args.models is not None``).
        run: does the work for a selected invocation.
        needs: modules the extension needs at run time.
    """

    command: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    selected: Callable[[argparse.Namespace], bool]
    run: Callable[[argparse.Namespace], int]
    needs: Needs = field(default_factory=Needs)


# --- the small languages of api.md ------------------------------------------------------------------


def int_at_least(minimum: int) -> Callable[[str], int]:
    """An argparse ``type=``: an integer >= ``minimum`` (errors become ``argument --FLAG: got ...``)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum:
            raise argparse.ArgumentTypeError(f"got {text!r}, expected an integer >= {minimum}")
        return value

    parse.__name__ = f"integer >= {minimum}"
    return parse


SEED_LIMIT = 2**63
"""Seeds are stored as SQLite INTEGERs (signed 64-bit), so every seed is below 2**63."""


def parse_seeds(text: str | int, flag: str = "--seeds") -> list[int]:
    """``20`` -> 0..19; ``5:10`` -> 5..9 (half-open, like ``range``).

    Raises:
        CLIError: anything else, no seed, a negative seed, or a seed of 2**63 or more (the store
            could not hold it, and the flown episode would be lost when its row is written).
    """
    text = str(text).strip()
    try:
        if ":" in text:
            start, stop = (int(part) for part in text.split(":", 1))
        else:
            start, stop = 0, int(text)
    except ValueError:
        raise CLIError(
            f"{flag}: got {text!r}, expected a count N (seeds 0..N-1) or START:STOP (half-open)"
        ) from None
    if not 0 <= start < stop <= SEED_LIMIT:
        raise CLIError(
            f"{flag}: got {text!r}, expected a count N with 1 <= N <= 2**63 (seeds 0..N-1) or START:STOP "
            "with 0 <= START < STOP <= 2**63 (seeds are signed 64-bit integers in the store)"
        )
    return list(range(start, stop))


def parse_weights(text: str | Sequence[float] | None) -> tuple[float, float, float] | None:
    """``0.3,0.5,0.2`` -> (0.3, 0.5, 0.2) (terrain, radar, third term); the sum is checked by the scenario.

    Raises:
        CLIError: not three numbers.
    """
    if text is None:
        return None
    expected = "expected three comma-separated numbers summing to 1"
    try:
        values = [float(v) for v in (text.split(",") if isinstance(text, str) else text)]
    except ValueError:
        raise CLIError(f"--weights: got {text!r}, {expected}") from None
    if len(values) != 3:
        raise CLIError(f"--weights: got {text!r}, {expected}")
    return (values[0], values[1], values[2])


def split_list(values: str | Sequence[str] | None) -> list[str]:
    """Accept both ``--policies a b`` and ``--policies a,b`` (and a single string from a config file)."""
    items = [values] if isinstance(values, str) else list(values or [])
    return [part for value in items for part in str(value).split(",") if part]


def resolve_scenarios(
    specs: Sequence[str],
    profile: str | None = None,
    weights: tuple[float, float, float] | None = None,
    difficulty: float = 0.5,
    *,
    flag: str = "--scenarios",
) -> list[Any]:
    """The scenarios of catalogue names, ``random:`` forms or YAML paths, with a profile and weights.

    Names resolve in :func:`uav_penetration_env.catalogue.resolve_scenarios`.

    Args:
        specs: what the user typed.
        profile: ``benchmark`` or ``paper`` (``None``: each scenario's own).
        weights: objective weights replacing the scenarios' (``None``: their own).
        difficulty: difficulty of ``random:`` scenarios.
        flag: the flag to name in errors.

    Raises:
        CLIError: an unknown name (with a did-you-mean) or a broken scenario, naming ``flag``.
    """
    from uav_penetration_env.catalogue import UnknownScenarioError
    from uav_penetration_env.catalogue import resolve_scenarios as resolve_catalogue
    from uav_penetration_env.scenario import ScenarioError

    scenarios = []
    for spec in specs:
        try:
            for scenario in resolve_catalogue(spec, difficulty):
                if weights is not None:
                    scenario = scenario.updated({"cost": {"weights": list(weights)}})
                scenarios.append(scenario.with_profile(profile))
        except UnknownScenarioError as error:
            raise CLIError(f"{flag}: {error}") from None
        except ScenarioError as error:
            if error.field == "scenario":  # a bad ``random:`` form: the flag is the field
                raise CLIError(f"{flag}: got {spec!r}, expected {error.expected}") from None
            raise CLIError(f"{flag}: scenario {spec!r}: {error}") from None
    return scenarios


# --- files and folders ----------------------------------------------------------------------------


# The longest file or folder name, and the longest path, the common file systems take (ext4, APFS,
# NTFS: 255; Linux's PATH_MAX: 4096): longer ones fail with Errno 36 deep inside a command.
NAME_MAX = 255
PATH_MAX = 4096


def path_argument(text: str) -> str:
    """An argparse ``type=`` of every path flag: a usable path, returned as typed.

    Errors become ``argument --FLAG: got ...``: an empty value (which ``Path`` reads as the current
    folder), a NUL character, a name of more than :data:`NAME_MAX` characters or a path of more
    than :data:`PATH_MAX`, each of which the operating system would refuse mid-way.
    """
    shown = repr(text) if len(text) <= 60 else f"{text[:40]!r}... ({len(text)} characters)"
    if not text.strip():
        raise argparse.ArgumentTypeError(f"got {text!r}, expected a file or folder path")
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"got {shown}, expected a path without a NUL character")
    longest = max(Path(text).parts, key=len, default="")
    if len(longest) > NAME_MAX:
        raise argparse.ArgumentTypeError(
            f"got {shown}, a name of {len(longest)} characters; expected names of at most {NAME_MAX}"
        )
    if len(text) > PATH_MAX:
        raise argparse.ArgumentTypeError(f"got {shown}, expected a path of at most {PATH_MAX} characters")
    return text


path_argument.__name__ = "path"


def add_store_argument(parser: argparse.ArgumentParser, *, default: Path | None = DEFAULT_STORE) -> None:
    """The ``--store`` flag (``default=None``: the command applies :data:`DEFAULT_STORE` itself)."""
    parser.add_argument(
        "--store",
        type=path_argument,
        default=None if default is None else str(default),
        help=f"results store (default: {DEFAULT_STORE})",
    )


def store_error(error: StoreError, flag: str = "--store") -> CLIError:
    """The one-line CLI form of a store problem: ``--store PATH: what is wrong``."""
    return CLIError(f"{flag} {error.path}: {error.reason}")


def existing_store(path: str | Path) -> Path:
    """The path of a results store that must already exist (leaderboard, plot, export).

    The file is inspected by reading only (:func:`~uav_penetration_env.benchmark.store.inspect_store_file`),
    so a bad one is refused before anything is written anywhere, and is left byte for byte as it was.

    Raises:
        CLIError: ``--store PATH: ...`` for no file there, a folder, an unreadable path, a damaged
            file, a file that is not a results store, or a store of a newer schema.
    """
    from uav_penetration_env.benchmark.store import StoreError, inspect_store_file

    store = Path(path)
    try:
        inspect_store_file(store, must_exist=True)
    except StoreError as error:
        raise store_error(error) from None
    return store


OUT_SOURCE_FILE = ".uav-bench-source"  # in an output folder: the store (or rows) its files were written from


def check_out_folder(out: Path, source: str | Path, *, replace: bool = False, flag: str = "--out") -> None:
    """Refuse an output folder that holds another store's tables and report (see :func:`record_out_folder`).

    DECISION (api.md §4.7, outputs of one store): a command writing tables, figures or a report
    records in the folder, once its files are written, which store (or exported rows) they come
    from. A later command from another source refuses the folder in one line, before any work,
    rather than mixing two stores' files or replacing the first's report; ``--replace-out`` says
    the replacement is meant. A folder with no record (written before this rule, or by hand) is
    taken as it is.

    Raises:
        CLIError: the folder's files come from another source and ``replace`` is False.
    """
    theirs = _out_source(out)
    mine = _source_key(source)
    if theirs and theirs != mine and not replace:
        raise CLIError(
            f"{flag} {out}: holds the tables and report of {theirs}; expected a folder of {mine}'s own "
            "(choose another --out, or --replace-out to replace them)"
        )


def record_out_folder(out: Path, source: str | Path) -> None:
    """Record ``source`` as the origin of ``out``'s files (after they are written; atomic)."""
    if _out_source(out) == _source_key(source):
        return
    from uav_penetration_env.atomic import write_text_atomic

    try:
        write_text_atomic(out / OUT_SOURCE_FILE, _source_key(source) + "\n")
    except OSError:
        pass  # the outputs are written; a folder that takes no more files only loses the record


def _source_key(source: str | Path) -> str:
    return str(Path(source).expanduser().resolve())


def _out_source(out: Path) -> str:
    try:
        return (out / OUT_SOURCE_FILE).read_text(encoding="utf-8").strip()
    except (OSError, UnicodeDecodeError):
        return ""


def add_replace_out_argument(parser: argparse.ArgumentParser) -> None:
    """``--replace-out``: write into an --out folder that holds another store's outputs (:func:`check_out_folder`)."""
    parser.add_argument(
        "--replace-out",
        action="store_true",
        default=None,
        help="write into an --out folder holding another store's tables and report, replacing them",
    )


def result_tables(args: argparse.Namespace, default_store: Path | None = None) -> Any:
    """The row tables of ``--rows STEM ...`` (exported rows or checkpoint folders) or ``--store PATH``.

    Args:
        args: the parsed flags (``rows``: a list of stems or None; ``store``: a path or None).
        default_store: the store read when neither is given (None: one of them is required).

    Returns:
        The :class:`~uav_penetration_env.benchmark.rows.ResultTables`.

    Raises:
        CLIError: both given, neither (without a default), unreadable rows or a missing store.
    """
    from uav_penetration_env.benchmark.rows import RowsError, read_chunks, store_tables

    if args.rows is not None and args.store is not None:
        raise CLIError("--rows and --store: give one source of results, not both")
    if args.rows is not None:
        try:
            return read_chunks(args.rows)
        except RowsError as error:
            raise CLIError(str(error)) from None
    if args.store is None and default_store is None:
        raise CLIError("--rows, --store: expected one source of results (exported rows or a checkpoint folder, or a store)")
    return store_tables(existing_store(args.store if args.store is not None else default_store))


def add_fixed_target_rule_argument(parser: argparse.ArgumentParser) -> None:
    """``--fixed-target-rule``: how the window studies are compared (api.md §4.8); checked by :func:`fixed_target_rule`."""
    parser.add_argument(
        "--fixed-target-rule",
        default="coco",
        metavar="RULE",
        help="the window comparisons: coco (default: targets per window from every run, windows as units) or "
        "worse-final (retired: the pair's worse final as target; only to rebuild leaderboards v2 and v3)",
    )


def fixed_target_rule(args: argparse.Namespace) -> str:
    """The checked ``--fixed-target-rule`` (one of :data:`~..fixedtarget.FIXED_TARGET_RULES`).

    Raises:
        CLIError: another value.
    """
    from uav_penetration_env.benchmark.fixedtarget import FIXED_TARGET_RULES

    if args.fixed_target_rule not in FIXED_TARGET_RULES:
        raise CLIError(
            f"--fixed-target-rule: got {args.fixed_target_rule!r}, expected one of {', '.join(FIXED_TARGET_RULES)}"
        )
    return str(args.fixed_target_rule)


@contextlib.contextmanager
def removed_if_failed(path: Path) -> Iterator[None]:
    """Remove the folders of ``path`` that the block made, when it raises and they are still empty.

    ``path`` itself and its parents that do not exist yet are removed again, deepest first, so a
    failed command leaves no empty output folder behind (api.md §4.7).
    """
    missing = [folder for folder in [path, *path.parents] if not folder.exists()]
    try:
        yield
    except BaseException:
        for folder in missing:
            try:
                folder.rmdir()
            except OSError:  # not empty (something was written), or not ours to remove
                break
        raise


def check_writable_folder(path: Path, flag: str, value: str | Path | None = None) -> None:
    """Create ``path`` if needed and check a file can be written there.

    Args:
        path: the folder.
        flag: the flag to name in the error.
        value: what the user typed for ``flag``, if not ``path`` itself (``--store``: the file).

    Raises:
        CLIError: ``FLAG VALUE: cannot write to FOLDER (reason); expected a writable folder``.
    """
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".uav-bench-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as error:
        raise CLIError(
            f"{flag} {path if value is None else value}: cannot write to {path} "
            f"({error.strerror or error}); expected a writable folder"
        ) from None


def write_csv_tables(out: Path, tables: Sequence[tuple[str, Any]], written_before: Sequence[str] = ()) -> None:
    """Write each ``(file name, DataFrame)`` of ``tables`` as CSV in ``out``; print one line naming them.

    The line names the first file with its folder, then the others by name: ``written_before``
    (files the command wrote itself, e.g. a page) first, then ``tables`` in order.
    """
    from uav_penetration_env.benchmark.rows import write_table

    for name, frame in tables:
        write_table(frame, out / name, "csv")
    first, *rest = [*written_before, *(name for name, _ in tables)]
    listed = f"{', '.join(rest[:-1])} and {rest[-1]}" if len(rest) > 1 else "".join(rest)
    print(f"wrote {out / first}" + (f", {listed}" if rest else ""))


def command_line(args: argparse.Namespace) -> str:
    """The command as typed (``uav-bench run --seeds 3``), for provenance in tables and files."""
    return " ".join(["uav-bench", *map(shlex.quote, getattr(args, "argv", []))])


def reference_names(tables: Any) -> list[str]:
    """Every name a ``--reference`` may give for these results.

    Policy names, their table labels (``name@hash8`` where one name has several configurations)
    and the window runs' optimisers.
    """
    from uav_penetration_env.benchmark.leaderboard.groups import policy_labels

    episodes, windows = tables.episodes, tables.window_runs
    names = set(episodes["policy"].dropna().astype(str)) if "policy" in episodes else set()
    if len(episodes):
        names |= set(policy_labels(episodes).astype(str))
    if "optimizer" in windows:
        names |= set(windows["optimizer"].dropna().astype(str))
    return sorted(names)


def check_reference(reference: str, known: Sequence[str]) -> None:
    """Refuse a ``--reference`` that names nothing stored (the tables would silently pick another).

    Raises:
        CLIError: ``known`` is not empty and ``reference`` is not in it.
    """
    from uav_penetration_env.suggest import did_you_mean

    known = sorted({str(p) for p in known})
    if known and reference not in known:
        raise CLIError(
            f"--reference {reference}: no such policy in the results; {did_you_mean(reference, known)}"
            f"expected one of {', '.join(known[:12])}{', ...' if len(known) > 12 else ''}"
        )
