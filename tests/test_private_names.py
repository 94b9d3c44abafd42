"""No private name crosses a module boundary in ``beam/`` and ``dashboard/``.

An AST scan of every module for

* ``from X import _name`` (or ``import X._mod``) where ``X`` is another module of the project:
  a name a module keeps private is not another module's to import (a private *module* is open
  to the modules of its own package only);
* attribute reads ``obj._name`` where ``obj`` is not ``self``/``cls`` and ``_name`` is not an
  attribute the scanned module defines itself (a class's private attribute read by another
  instance of the same class, in the same module, is that module's business).

The only exceptions are the Panel internals listed in :data:`PANEL_INTERNALS`, each where Panel
has no public way and commented so in its module.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("beam", "dashboard")

#: (module path, attribute) of the Panel internals used on purpose; each use carries a comment
#: naming the Panel version or issue that leaves no public way.
PANEL_INTERNALS = {
    ("dashboard/app.py", "_template_variables"),
    ("dashboard/views/panes.py", "_get_properties"),
    ("dashboard/views/panes.py", "_transform_object"),
}
#: The public API of :func:`collections.namedtuple` (its names start with an underscore).
NAMEDTUPLE_API = {"_asdict", "_replace", "_fields", "_make"}


def _modules(root: Path) -> list[Path]:
    return sorted(p for package in PACKAGES for p in (root / package).rglob("*.py"))


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _package_of(path: Path, root: Path) -> str:
    return ".".join(path.relative_to(root).parts[:-1])


def _own_names(tree: ast.AST) -> set[str]:
    """Private names the module defines: functions, classes, assigned names and attributes."""
    own = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            own.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            own.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            own.add(node.attr)
        elif isinstance(node, ast.arg):
            own.add(node.arg)
        elif isinstance(node, ast.keyword) and node.arg:  # e.g. _draws=... passed to an own dataclass
            own.add(node.arg)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.isidentifier():
            own.add(node.value)  # __slots__ entries, setattr names
    return {n for n in own if _private(n)}


def _outside_modules(tree: ast.AST) -> set[str]:
    """Names bound to modules from outside the project (``import argparse``, ``import sys``): their
    underscore names are the standard library's or a third party's business, not this rule's."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] not in PACKAGES:
                    names.add(alias.asname or alias.name.split(".")[0])
    return names


def violations(root: Path = ROOT) -> list[str]:
    """Every private reach across modules in the project under ``root`` (``file:line: what``)."""
    found = []
    for path in _modules(root):
        rel = path.relative_to(root).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=rel)
        package = _package_of(path, root)
        own = _own_names(tree)
        outside = _outside_modules(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                    and node.module.split(".")[0] in PACKAGES:
                parts = node.module.split(".")
                for i, part in enumerate(parts):
                    if _private(part) and ".".join(parts[:i]) != package:
                        found.append(f"{rel}:{node.lineno}: imports the private module {node.module}")
                for alias in node.names:
                    if _private(alias.name) and node.module != _module_name(path, root):
                        found.append(f"{rel}:{node.lineno}: imports {alias.name} from {node.module}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    parts = alias.name.split(".")
                    if parts[0] in PACKAGES and any(_private(p) and ".".join(parts[:i]) != package
                                                    for i, p in enumerate(parts)):
                        found.append(f"{rel}:{node.lineno}: imports the private module {alias.name}")
            elif isinstance(node, ast.Attribute) and _private(node.attr) and isinstance(node.ctx, ast.Load):
                owner = node.value
                if isinstance(owner, ast.Name) and (owner.id in ("self", "cls") or owner.id in outside):
                    continue
                if node.attr in own or node.attr in NAMEDTUPLE_API or (rel, node.attr) in PANEL_INTERNALS:
                    continue
                found.append(f"{rel}:{node.lineno}: reads {ast.unparse(owner)}.{node.attr}")
    return found


def test_no_private_name_crosses_a_module():
    assert violations() == []


def test_the_scan_finds_each_kind_of_private_reach(tmp_path):
    """The scan on a small project written here: the reaches it must refuse are found, what a
    module does with its own names (and the standard library's) is not."""
    (tmp_path / "beam" / "inner").mkdir(parents=True)
    (tmp_path / "dashboard").mkdir()
    (tmp_path / "beam" / "inner" / "_hidden.py").write_text("def helper():\n    return 1\n")
    (tmp_path / "beam" / "inner" / "own.py").write_text(
        "import argparse\nfrom beam.inner._hidden import helper\n\n"
        "class Box:\n    def __init__(self):\n        self._size = 1\n\n    def same(self, other):\n"
        "        return other._size == self._size\n\n"
        "def parser(sub: argparse._SubParsersAction):\n    return sub\n")
    (tmp_path / "dashboard" / "reach.py").write_text(
        "from beam.inner.own import _secret\nimport beam.inner._hidden\n\n"
        "def lower(problem):\n    return problem._lower\n")
    found = violations(tmp_path)
    assert found == [
        "dashboard/reach.py:1: imports _secret from beam.inner.own",
        "dashboard/reach.py:2: imports the private module beam.inner._hidden",
        "dashboard/reach.py:5: reads problem._lower",
    ], found


def test_the_panel_internals_are_commented_where_they_are_used():
    """Each use of a Panel internal (a read, or the method that overrides it) has a comment naming
    the Panel version within the three lines above it or above its method."""
    for rel, attr in PANEL_INTERNALS:
        lines = (ROOT / rel).read_text(encoding="utf-8").splitlines()
        uses = [i for i, line in enumerate(lines) if f".{attr}" in line or f"def {attr}(" in line]
        assert uses, (rel, attr)
        for i in uses:
            start = i
            while start > 0 and not lines[start].lstrip().startswith("def "):
                start -= 1
            context = " ".join(lines[max(i - 3, 0):i + 1] + lines[max(start - 3, 0):start + 1])
            assert re.search(r"Panel \d", context), (rel, attr, lines[i])
