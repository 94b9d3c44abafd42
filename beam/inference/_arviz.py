"""Import ArviZ without letting it pull in a UI toolkit.

ArviZ 0.x validates its default ``rcParams`` when it is imported and, if bokeh is installed
(the dashboard extra installs it), imports ``bokeh.core.enums`` to check a plot-marker name,
although nothing in :mod:`beam.inference` plots. The ``beam`` package is headless (it must never
import panel, holoviews or bokeh), so its first import of ArviZ makes those packages
unimportable for the duration of that import; ArviZ then uses its built-in list of marker
names (its own ``ImportError`` fallback). When one of them is already loaded (the dashboard
process) nothing is blocked.
"""

from __future__ import annotations

import importlib.abc
import sys
import threading
from types import ModuleType

__all__ = ["import_arviz"]

_UI_PACKAGES = ("bokeh", "panel", "holoviews")
_lock = threading.Lock()


class _BlockUIPackages(importlib.abc.MetaPathFinder):
    """Refuses the UI packages; every other module is left to the normal finders."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname.partition(".")[0] in _UI_PACKAGES:
            raise ModuleNotFoundError(f"{fullname} is not imported by the headless beam package", name=fullname)


def import_arviz() -> ModuleType:
    """The ``arviz`` module, imported without bokeh / panel / holoviews if none is loaded yet."""
    module = sys.modules.get("arviz")
    if module is not None:
        return module
    with _lock:
        if any(name in sys.modules for name in _UI_PACKAGES):
            import arviz

            return arviz
        finder = _BlockUIPackages()
        sys.meta_path.insert(0, finder)
        try:
            import arviz
        finally:
            sys.meta_path.remove(finder)
        return arviz
