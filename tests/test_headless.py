"""The library never imports a UI toolkit."""

import subprocess
import sys

CODE = """
import sys, importlib, pkgutil, beam
for info in pkgutil.walk_packages(beam.__path__, 'beam.'):
    if not info.name.endswith('__main__'):
        importlib.import_module(info.name)
print(','.join(m for m in ('panel', 'holoviews', 'bokeh') if m in sys.modules))
"""


def test_importing_beam_loads_no_ui_library():
    result = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == ""
