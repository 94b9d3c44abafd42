"""MkDocs hook: every page of ``docs/`` is in the navigation, under its own title.

The build fails (:class:`mkdocs.exceptions.PluginError`) when a page ``docs/<topic>.md`` is not
named in the ``nav`` of ``mkdocs.yml``, when the nav names a page that does not exist, or when
the nav gives a page a title of its own (a page is listed by its file name, and MkDocs shows its
first heading). So a new page cannot be left out of the site, nor listed under a file name: add
it to the nav where a user would look for it. :func:`nav_problems` is the check, also run by
``tests/test_docs_nav.py``.
"""

from __future__ import annotations

from pathlib import Path


def _pages(nav) -> list[tuple[str | None, str]]:
    """(title or None, file) of every page the nav names, at any depth, in order."""
    found: list[tuple[str | None, str]] = []
    for item in nav or []:
        if isinstance(item, str):
            found.append((None, item))
            continue
        for title, value in item.items():
            if isinstance(value, list):
                found += _pages(value)
            elif isinstance(value, str):
                found.append((title, value))
    return found


def nav_problems(nav, docs_dir) -> list[str]:
    """Every way the nav fails to show each page of ``docs_dir`` once, by its own title.

    Parameters
    ----------
    nav : list
        The ``nav`` of ``mkdocs.yml`` as MkDocs reads it (pages as file names relative to
        ``docs_dir``; sections as one-key mappings to lists).
    docs_dir : str or Path
        The documentation folder (its ``*.md`` files are the pages).

    Returns
    -------
    list of str
        One sentence per problem (empty when the nav is complete).
    """
    docs = Path(docs_dir)
    named = _pages(nav)
    files = [file for _, file in named if "://" not in file]
    problems = [f"{page.name} is not in the nav of mkdocs.yml: add it where a user would look for it"
                for page in sorted(docs.glob("*.md")) if page.name not in files]
    problems += [f"the nav names {file}, which is not a page of {docs}" for file in sorted(set(files))
                 if not (docs / file).is_file()]
    problems += [f"the nav names {file} more than once" for file in sorted(set(files)) if files.count(file) > 1]
    problems += [f"the nav titles {file} {title!r}: list it as '- {file}' (its first heading is its title)"
                 for title, file in named if title is not None and "://" not in file]
    return problems


def on_config(config, **_):
    from mkdocs.exceptions import PluginError

    problems = nav_problems(config.nav, config.docs_dir)
    if problems:
        raise PluginError("the site's navigation is incomplete:\n  " + "\n  ".join(problems))
    return config
