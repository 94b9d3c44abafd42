"""MkDocs hook: put every page of ``docs/`` in the navigation without editing ``mkdocs.yml``.

A page ``docs/<topic>.md`` that the ``nav`` of ``mkdocs.yml`` does not name is appended under
"More topics" (sorted by file name); a ``docs/decisions-<name>.md`` under "Design decisions".
So a new page is never left out of the site, and ``mkdocs build --strict`` still checks its links.
"""

from __future__ import annotations

from pathlib import Path


def _named(nav) -> set[str]:
    """Every page file the nav names, at any depth."""
    found: set[str] = set()
    for item in nav or []:
        value = next(iter(item.values())) if isinstance(item, dict) else item
        if isinstance(value, list):
            found |= _named(value)
        elif isinstance(value, str):
            found.add(value)
    return found


def _section(nav: list, title: str) -> list:
    for item in nav:
        if isinstance(item, dict) and title in item and isinstance(item[title], list):
            return item[title]
    section: list = []
    nav.append({title: section})
    return section


def on_config(config, **_):
    nav = config.nav
    if nav is None:  # no nav: MkDocs lists every page itself
        return config
    docs = Path(config.docs_dir)
    named = _named(nav)
    for page in sorted(docs.glob("*.md")):
        if page.name in named:
            continue
        if page.name.startswith("decisions-"):
            title = "Decisions: " + page.stem.removeprefix("decisions-")
            _section(nav, "Design decisions").append({title: page.name})
        else:
            _section(nav, "More topics").append(page.name)
    return config
