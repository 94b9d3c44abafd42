"""The python examples of the README and of the documentation pages run as written.

Every fenced ```` ```python ```` block of ``README.md`` and ``docs/*.md`` is executed from the
repository's root, the blocks of one page in order in one namespace (a page's later example
may use an earlier one's names). The examples carry their own ``assert`` lines, which state
what the text around them claims (e.g. the effect a bundled record hides). Blocks in other
languages (``bash``, ``toml``, ``text``) are not run.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```python[ \t]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)


def python_blocks(text: str) -> list[str]:
    """The source of every fenced python block of a Markdown text, in order."""
    return [match.group(1) for match in FENCE.finditer(text)]


def test_fence_pattern_finds_blocks_and_only_python_ones():
    text = "intro\n```python\nx = 1\n```\n```bash\nls\n```\ntext ```python``` inline\n```python\ny = x\n```\n"
    assert python_blocks(text) == ["x = 1\n", "y = x\n"]


def test_the_readme_has_a_python_example():
    assert python_blocks((ROOT / "README.md").read_text(encoding="utf-8"))


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if python_blocks(p.read_text(encoding="utf-8"))],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_page_examples_run(page: Path, monkeypatch):
    monkeypatch.chdir(ROOT)
    namespace: dict = {"__name__": f"docs_example_{page.stem}"}
    for index, source in enumerate(python_blocks(page.read_text(encoding="utf-8")), start=1):
        code = compile(source, f"{page.relative_to(ROOT)} [python block {index}]", "exec")
        exec(code, namespace)  # noqa: S102 - the documentation's own examples
