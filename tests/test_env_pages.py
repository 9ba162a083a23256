"""docs/hooks/env_pages.py: each env page's generated specification follows the code, and has its frame."""

from __future__ import annotations

import shutil

import pytest
from test_docs_site import load

from uav_penetration_env import ENV_IDS

env_pages = load("env_pages")  # a docs build script, loaded by path as mkdocs' hooks are


def test_every_env_page_is_what_the_code_gives():
    """docs/envs/*.md carry the block the registrations, spaces and docstrings give, and each frame exists."""
    assert env_pages.main(["--check"]) == 0


def test_a_stale_block_or_a_missing_frame_fails_the_check(tmp_path, capsys):
    docs = tmp_path / "docs"
    shutil.copytree(env_pages.ROOT / "docs" / "envs", docs / "envs")
    shutil.copytree(env_pages.ROOT / "docs" / "images" / "envs", docs / "images" / "envs")
    assert env_pages.main(["--check", "--docs", str(docs)]) == 0
    page = docs / "envs" / "UAVPenetrationDEM-v0.md"
    page.write_text(page.read_text().replace("| max_episode_steps | `", "| max_episode_steps | `9"))
    (docs / "images" / "envs" / "UAVPenetration-v0.png").unlink()
    assert env_pages.main(["--check", "--docs", str(docs)]) == 1
    err = capsys.readouterr().err
    assert "UAVPenetrationDEM-v0.md: its specification is stale" in err and "UAVPenetration-v0.png: missing" in err


def test_a_page_without_the_markers_is_refused(tmp_path):
    (tmp_path / "envs").mkdir()
    (tmp_path / "envs" / "UAVPenetration-v0.md").write_text("# UAVPenetration-v0\n\nno block\n")
    with pytest.raises(SystemExit, match=r"UAVPenetration-v0.md: no .* block to write the specification into"):
        env_pages.main(["--check", "--docs", str(tmp_path), "--ids", "UAVPenetration-v0"])


def test_every_registered_id_has_a_page():
    assert sorted(p.stem for p in (env_pages.ROOT / "docs" / "envs").glob("*.md")) == sorted(ENV_IDS)
