"""The site's navigation shows every page of ``docs/`` once, by its own title.

``mkdocs_hooks.py`` fails the MkDocs build on the same check (:func:`mkdocs_hooks.nav_problems`);
this test runs it without a build, on ``mkdocs.yml`` as written, and checks that the check
itself catches a page left out, a page listed under a title of its own, a page named twice and
a page that does not exist.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from mkdocs_hooks import nav_problems

ROOT = Path(__file__).resolve().parents[1]


def site_nav() -> list:
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))["nav"]


def test_every_page_is_in_the_nav_by_its_own_title():
    assert nav_problems(site_nav(), ROOT / "docs") == []


def test_the_design_decisions_are_one_page():
    assert (ROOT / "docs" / "decisions.md").is_file()
    assert sorted(p.name for p in (ROOT / "docs").glob("decisions*.md")) == ["decisions.md"]


def test_the_check_names_each_way_a_nav_can_fail(tmp_path):
    for name in ("index.md", "guide.md", "left-out.md"):
        (tmp_path / name).write_text(f"# {name}\n", encoding="utf-8")
    nav = ["index.md", {"Guide": [{"A title of its own": "guide.md"}, "index.md", "missing.md"]}]
    problems = nav_problems(nav, tmp_path)
    assert len(problems) == 4
    assert any(p.startswith("left-out.md is not in the nav") for p in problems)
    assert any("missing.md, which is not a page" in p for p in problems)
    assert any("index.md more than once" in p for p in problems)
    assert any("titles guide.md 'A title of its own'" in p for p in problems)
    assert nav_problems(["index.md", {"Guide": ["guide.md", "left-out.md"]}], tmp_path) == []
