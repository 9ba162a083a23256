"""Imports flow one way (docs/architecture.md): no cycles, the core never imports the RL extra or the harness.

scenario -> physics -> model -> env / vector env -> harness; ``optimizers`` stands alone;
``baselines`` (extra ``rl``) depends on the core, never the reverse; the env core
(``uav_penetration_env`` outside ``uav_penetration_env.benchmark``) never imports the harness. The graph is read from the
source with ``ast``, so imports inside functions count as much as those at the top of a module.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BUILD_OUTPUT = {"build", "dist"}  # top-level folders of setuptools' output, copies of the tree
# What the core (and the standalone optimisers) must never import, directly or inside a function.
RL_ONLY = ("baselines", "torch", "stable_baselines3")
CORE = ("uav_penetration_env", "optimizers")
# The harness: the env core (the rest of uav_penetration_env) never imports it, at any depth.
HARNESS = "uav_penetration_env.benchmark"


def module_files(root: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` file under ``root`` (hidden folders skipped)."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root).with_suffix("").parts
        if parts[0] in BUILD_OUTPUT or any(part.startswith(".") for part in parts[:-1]):
            continue  # build output, virtual environments, caches
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if parts:
            modules[".".join(parts)] = path
    return modules


def imported_names(source: str, module: str, is_package: bool) -> set[str]:
    """Every module name ``source`` imports, at any depth (functions, ``if TYPE_CHECKING``, ...).

    ``from a.b import c`` yields ``a.b.c``, which :func:`resolve` maps to the module ``a.b.c`` or,
    for a name defined in ``a.b``, to ``a.b``; relative imports are resolved against ``module``.
    Parent packages that Python initialises on the way (``a`` for ``import a.b``) are not edges:
    they run first, whatever the child imports.
    """
    package = module if is_package else module.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                origin = ".".join([*base, *([node.module] if node.module else [])])
            else:
                origin = node.module or ""
            names.update(f"{origin}.{alias.name}" for alias in node.names)
    return names


def resolve(name: str, modules: Iterable[str]) -> str | None:
    """The longest known module that ``name`` is or lies in (``a.b.func`` -> ``a.b``), else None."""
    known = set(modules)
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def import_graph(root: Path) -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    """The tree's import graph: module -> modules of the tree it imports, and module -> every name it imports."""
    files = module_files(root)
    graph: dict[str, set[str]] = {}
    raw: dict[str, set[str]] = {}
    for module, path in files.items():
        names = imported_names(path.read_text(), module, path.name == "__init__.py")
        raw[module] = names
        graph[module] = {target for n in names if (target := resolve(n, files)) and target != module}
    return graph, raw


def cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    lowlink: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(start: str) -> None:
        # Iterative depth-first search: the graph may be deeper than Python's recursion limit.
        work = [(start, iter(sorted(graph.get(start, ()))))]
        index[start] = lowlink[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = lowlink[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    lowlink[node] = min(lowlink[node], index[child])
                continue
            work.pop()
            if work:
                lowlink[work[-1][0]] = min(lowlink[work[-1][0]], lowlink[node])
            if lowlink[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def forbidden_imports(raw: Mapping[str, set[str]]) -> list[str]:
    """Violations of the direction rules, as ``importer -> imported`` lines."""
    problems = []
    for module, names in sorted(raw.items()):
        top = module.partition(".")[0]
        for name in sorted(names):
            imported_top = name.partition(".")[0]
            if top in CORE and imported_top in RL_ONLY:
                problems.append(f"{module} -> {name}")
            if top == "optimizers" and imported_top == "uav_penetration_env":
                problems.append(f"{module} -> {name}")
            if top == "uav_penetration_env" and not _in_harness(module) and _in_harness(name):
                problems.append(f"{module} -> {name}")
    return problems


def _in_harness(name: str) -> bool:
    """Whether a module (or a name defined in one) lies in the harness, ``uav_penetration_env.benchmark``."""
    return name == HARNESS or name.startswith(f"{HARNESS}.")


@pytest.fixture(scope="module")
def tree_graph():
    return import_graph(ROOT)


def test_the_graph_sees_the_packages_and_function_level_imports(tree_graph):
    graph, _ = tree_graph
    assert {
        "uav_penetration_env",
        "uav_penetration_env.benchmark.cli",
        "optimizers.pso",
        "baselines.plugin",
    } <= set(graph)
    # baselines.cli imports the harness's common CLI module at the top; policies.py imports
    # optimizers inside make_policy: both must be edges.
    assert "uav_penetration_env.benchmark.commands.common" in graph["baselines.cli"]
    assert "optimizers" in graph["uav_penetration_env.benchmark.policies"]


def test_no_import_cycle_anywhere_in_the_tree(tree_graph):
    graph, _ = tree_graph
    assert cycles(graph) == []


def test_the_core_never_imports_the_rl_extra_and_the_optimisers_stand_alone(tree_graph):
    _, raw = tree_graph
    assert forbidden_imports(raw) == []


def test_the_env_core_never_imports_the_harness(tree_graph):
    """No module of uav_penetration_env outside benchmark/ imports the harness, even inside a function.

    A frozen suite's check replays its stored controls (docs/suite.md §2): it used to fly the
    harness's greedy floor, from inside ``suites/fingerprint.py``.
    """
    _, raw = tree_graph
    core = {m: names for m, names in raw.items() if m.partition(".")[0] == "uav_penetration_env"}
    assert "uav_penetration_env.suites.fingerprint" in core and "uav_penetration_env.env" in core
    assert [line for line in forbidden_imports(core) if f"-> {HARNESS}" in line] == []


# --- the checks can fail: a synthetic tree -------------------------------------------------------------


def write(root: Path, files: Mapping[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_a_cycle_through_a_function_level_import_is_found(tmp_path):
    write(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/a.py": "from pkg import b\n",
            "pkg/b.py": "def late():\n    from . import c\n",
            "pkg/c.py": "import pkg.a\n",
            "pkg/d.py": "from pkg.a import something\n",  # into the cycle, not part of it
        },
    )
    graph, _ = import_graph(tmp_path)
    assert graph["pkg.b"] == {"pkg.c"} and graph["pkg.d"] == {"pkg.a"}
    assert cycles(graph) == [["pkg.a", "pkg.b", "pkg.c"]]


def test_a_leaf_importing_its_package_is_a_cycle(tmp_path):
    # The shape of the old cache.py: the package imports the leaf, the leaf imports the package.
    write(
        tmp_path,
        {"env/__init__.py": "from env.cache import key\n", "env/cache.py": "from env import version\n"},
    )
    assert cycles(import_graph(tmp_path)[0]) == [["env", "env.cache"]]


def test_forbidden_directions_are_reported(tmp_path):
    write(
        tmp_path,
        {
            "uav_penetration_env/__init__.py": "",
            "uav_penetration_env/harness.py": "def load():\n    from baselines import load_policy\n",
            "uav_penetration_env/suites/__init__.py": "",
            "uav_penetration_env/suites/check.py": "def replay():\n    from ..benchmark.policies import Greedy\n",
            "uav_penetration_env/benchmark/__init__.py": "from uav_penetration_env import harness\n",
            "uav_penetration_env/benchmark/policies.py": "import uav_penetration_env.suites.check\n",
            "optimizers/__init__.py": "import numpy\n",
            "optimizers/pso.py": "import torch.nn\nfrom uav_penetration_env import harness\n",
            "baselines/__init__.py": "import torch\nimport uav_penetration_env\n",  # allowed direction
        },
    )
    _, raw = import_graph(tmp_path)
    assert forbidden_imports(raw) == [
        "optimizers.pso -> torch.nn",
        "optimizers.pso -> uav_penetration_env.harness",
        "uav_penetration_env.harness -> baselines.load_policy",
        "uav_penetration_env.suites.check -> uav_penetration_env.benchmark.policies.Greedy",
    ]


LIGHT_FORBIDDEN = ("numba", "pandas", "matplotlib", "torch", "stable_baselines3", "optuna", "scipy.optimize")


PARSER_COMMANDS = (
    "--help",
    "run",
    "leaderboard",
    "plot",
    "windows",
    "report",
    "export",
    "train",
    "tune",
    "distill",
)


def test_the_cli_parser_loads_neither_the_physics_nor_the_heavy_libraries():
    """``uav-bench --help`` and argument errors answer at once: the parser imports no compiled code.

    One fresh interpreter, as the console script is, builds each command's parser in turn and says
    which first loaded a heavy module (each command's flags import only what they need); the
    registered env ids are there too.
    """
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from uav_penetration_env.benchmark import cli\n"
        f"for command in {PARSER_COMMANDS!r}:\n"
        "    cli.build_parser([command])\n"
        f"    heavy = sorted(m for m in {LIGHT_FORBIDDEN!r} if m in sys.modules)\n"
        "    if heavy:\n"
        "        print(command, heavy)\n"
        "        break\n"
        "import gymnasium\n"
        "assert 'UAVPenetration-v0' in gymnasium.registry\n"
        "print('light')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "light", out.stdout


def test_the_package_exports_load_on_first_use():
    import subprocess
    import sys

    code = (
        "import sys, uav_penetration_env as u\n"
        "assert 'numba' not in sys.modules\n"
        "assert u.PenetrationModel.__name__ == 'PenetrationModel' and 'numba' in sys.modules\n"
        "assert set(u.__all__) <= set(dir(u))\n"
        "try:\n    u.no_such_name\nexcept AttributeError as e:\n    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "module 'uav_penetration_env' has no attribute 'no_such_name'"


def test_an_export_named_like_its_submodule_stays_the_export_after_the_submodule_is_imported():
    import subprocess
    import sys

    code = (
        "import uav_penetration_env.benchmark.store\n"
        "from uav_penetration_env.benchmark.evaluate import policy_hash\n"  # binds the submodule on the package
        "from uav_penetration_env.benchmark import evaluate\n"
        "import uav_penetration_env.benchmark as b\n"
        "print(callable(evaluate), b.evaluate is evaluate, evaluate.__module__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.split() == ["True", "True", "uav_penetration_env.benchmark.evaluate"]


def test_the_exports_are_read_module_by_module_and_a_name_has_one_module():
    from uav_penetration_env.lazy import exported_modules

    exports = exported_modules({".build": ("BuiltScenario", "build_scenario"), "json": ("dumps",)})
    assert exports == {"BuiltScenario": ".build", "build_scenario": ".build", "dumps": "json"}
    with pytest.raises(ValueError, match=r"^dumps: exported by json and \.codec, expected one module$"):
        exported_modules({"json": ("dumps",), ".codec": ("dumps",)})


def test_uav_bench_help_imports_neither_the_harness_nor_the_scenarios():
    """``uav-bench --help`` answers in a fraction of a second: none of these load for it (issue: a slow CLI)."""
    import subprocess
    import sys

    heavy = [
        "pandas",
        "scipy",
        "matplotlib",
        "plotly",
        "uav_penetration_env.catalogue",
        "uav_penetration_env.scenario",
    ]
    code = (
        "import contextlib, io, sys\n"
        "from uav_penetration_env.benchmark.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        "    main(['--help'])\n"
        f"print(sorted(m for m in {heavy!r} if m in sys.modules))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    assert result.stdout.strip() == "[]", result.stdout
