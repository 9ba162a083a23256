"""The column glossary: every column as Markdown, and the generated page docs/columns.md.

``tests/test_docs.py`` fails when docs/columns.md differs from :func:`glossary_page`; regenerate
it with the command at the page's top.
"""

from __future__ import annotations

from uav_penetration_env.benchmark.columns.layout import leaderboard_columns
from uav_penetration_env.benchmark.columns.registry import EPISODE, RL_GROUP, STEP, WINDOW_RUN


def glossary_markdown() -> str:
    """Every column as Markdown: the column glossary of docs/columns.md (generated; do not edit it).

    Returns:
        Five tables (episode, step, leaderboard, window-run and RL-group columns), no trailing newline.
    """

    def escape(text: str) -> str:
        return text.replace("|", "\\|")

    lines = [
        "### Episode columns (`episodes` table, one row per episode)",
        "",
        "| column | type | definition | leaderboard |",
        "| --- | --- | --- | --- |",
    ]
    for column in EPISODE:
        shown = f"{column.board.header} ({column.board.aggregate.replace('_', ' ')})" if column.board else ""
        lines.append(
            f"| `{column.name}` | {column.sql.split()[0]} | {escape(column.definition)} | {escape(shown)} |"
        )
    lines += [
        "",
        "### Step columns (`steps` table, one row per track point; step 0 is the start state)",
        "",
        "| column | type | definition |",
        "| --- | --- | --- |",
    ]
    for column in STEP:
        lines.append(f"| `{column.name}` | {column.sql.split()[0]} | {escape(column.definition)} |")
    lines += [
        "",
        "### Leaderboard columns (one row per policy; the CSV holds every interval bound too)",
        "",
        "| header | CSV columns | definition |",
        "| --- | --- | --- |",
    ]
    for column in leaderboard_columns():
        board = column.board
        definition = (board.legend or column.definition).format(resamples="10,000")
        header = board.header.format(reference="reference")
        csv = ", ".join(f"`{name}`" for name in column.csv)
        lines.append(f"| {escape(header)} | {csv} | {escape(definition)} |")
    lines += [
        "",
        "### Window-run columns (`window_runs` table, one row per optimiser run on a stored MPC window state; `uav-bench windows`)",
        "",
        "| column | type | definition |",
        "| --- | --- | --- |",
    ]
    for column in WINDOW_RUN:
        lines.append(f"| `{column.name}` | {column.sql.split()[0]} | {escape(column.definition)} |")
    lines += [
        "",
        "### RL-group columns (`<stem>-rl.csv`, one row per RL group and reference policy; docs/rl-statistics.md §2)",
        "",
        "| header | CSV columns | definition |",
        "| --- | --- | --- |",
    ]
    for column in RL_GROUP:
        board = column.board
        header = board.header.format(planner="best planner")
        csv = ", ".join(f"`{name}`" for name in column.csv)
        lines.append(f"| {escape(header)} | {csv} | {escape(board.legend.format(resamples='10,000'))} |")
    return "\n".join(lines)


GLOSSARY_PAGE_HEADER = """# Result columns

Every column of the results store and the leaderboards, as declared once in
`uav_penetration_env/benchmark/columns/registry.py` ([architecture.md](architecture.md), "add a
result column"). This page is generated from that table and `tests/test_docs.py` fails when it is
out of date; regenerate it with

```bash
python -c "from uav_penetration_env.benchmark.columns import glossary_page; print(glossary_page(), end='')" > docs/columns.md
```

"""


def glossary_page() -> str:
    """``docs/columns.md``: a short header and :func:`glossary_markdown`, newline-terminated."""
    return GLOSSARY_PAGE_HEADER + glossary_markdown() + "\n"
