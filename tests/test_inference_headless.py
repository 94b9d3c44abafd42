"""Running the inference (including ArviZ diagnostics and netCDF output) loads no UI toolkit."""

from __future__ import annotations

import subprocess
import sys

CODE = """
import sys, tempfile, os
from beam.toy import ToyScenario, run_toy
from beam.inference import load_inference_data
result = run_toy(ToyScenario(target_ess=200))
with tempfile.TemporaryDirectory() as d:
    load_inference_data(result.posterior.to_netcdf(os.path.join(d, "p.nc")))
print(','.join(m for m in ('panel', 'holoviews', 'bokeh') if m in sys.modules))
"""


def test_sampling_and_arviz_output_load_no_ui_library():
    proc = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == ""
