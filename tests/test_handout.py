"""The one-page printable summary: self-contained HTML with inline SVG and the key numbers of the run."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from beam.io.handout import Series, band_svg, handout_html, micrometres, nice_ticks

#: Anything that would make a browser fetch something: a URL with a scheme or protocol-relative,
#: a src / href attribute, a CSS import or a url() that is not a same-document #fragment.
EXTERNAL = re.compile(r"(?i)(\b[a-z][a-z0-9+.-]*://|[\"'(]//|\bsrc\s*=|\bhref\s*=|@import|url\((?!#)|<script|<link)")


def assert_self_contained(text: str) -> None:
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")
    found = EXTERNAL.findall(text)
    assert found == [], f"external references: {found[:5]}"


def test_nice_ticks_are_round_and_cover_the_range():
    np.testing.assert_allclose(nice_ticks(0.0, 10.3), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0])
    np.testing.assert_allclose(nice_ticks(-0.013, 0.021, 5), [-0.01, 0.0, 0.01, 0.02])
    np.testing.assert_allclose(nice_ticks(1.0, 2.0), [1.0, 1.2, 1.4, 1.6, 1.8, 2.0])


def test_band_svg_maps_data_linearly_into_the_plot_area():
    t = np.linspace(0.0, 10.0, 11)
    svg = band_svg([Series("line", t, 2.0 * t - 5.0)], title="T", x_label="Time (s)", y_label="y (mm)")
    points = np.array([[float(v) for v in p.split(",")] for p in
                       re.search(r'<polyline[^>]*points="([^"]+)"', svg).group(1).split()])
    assert points.shape == (11, 2)
    # x increases with t, y (downward on screen) decreases with the value, both linearly
    np.testing.assert_allclose(np.diff(points[:, 0]), np.diff(points[:, 0])[0], atol=0.11)
    np.testing.assert_allclose(np.diff(points[:, 1]), np.diff(points[:, 1])[0], atol=0.11)
    assert np.diff(points[:, 0])[0] > 0 > np.diff(points[:, 1])[0]
    assert "<script" not in svg and "xmlns" not in svg


def test_micrometres_never_print_an_exponent():
    assert (micrometres(1.2734e-3), micrometres(3.2149e-6), micrometres(float("nan"))) == ("1273 µm", "3.21 µm", "–")


def test_handout_escapes_text_and_is_self_contained():
    text = handout_html("A <b> title", "sub & line", [("rmse", "3.2 µm")], [("T", ["a"], [["<x>"]])], [], ["note"])
    assert_self_contained(text)
    assert "A &lt;b&gt; title" in text and "&lt;x&gt;" in text and "3.2 µm" in text


def test_calibrate_report_is_self_contained_and_carries_the_key_numbers(tmp_path):
    report = tmp_path / "run.html"
    result = subprocess.run([sys.executable, "-m", "beam", "calibrate", "lab_run_1", "--steps", "60", "--walkers", "16",
                             "--json", "--report", str(report)], capture_output=True, text=True, timeout=300,
                            check=False)
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["report"] == str(report)
    text = report.read_text(encoding="utf-8")
    assert_self_contained(text)
    assert text.count("<svg") == 1 and "<polygon" in text and "<polyline" in text
    assert f"{round(1e6 * summary['rmse_prediction'])} µm" in text  # lab_run_1 misses its patch: > 100 µm
    assert f"{100 * summary['coverage95_prediction']:.1f} %" in text
    assert f"{round(1e6 * summary['noise_sd']['mean'])} µm" in text
    for values in summary["parameters"].values():
        assert f"{values['mean']:.4g}" in text
    assert "Air damping" in text and "lab_run_1" in text


@pytest.mark.parametrize("name", ["run.pdf", "run"])
def test_report_must_be_an_html_file(tmp_path, name):
    result = subprocess.run([sys.executable, "-m", "beam", "calibrate", "lab_run_1", "--report", str(tmp_path / name)],
                            capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [f"error: --report must name an .html file, got '{tmp_path / name}'"]
