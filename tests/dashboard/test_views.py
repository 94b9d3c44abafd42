"""The app and the toy view built without a browser: structure, labels, updates of the plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import panel as pn
import pytest
from bokeh.document import Document
from bokeh.models import ColumnDataSource
from panel.io.state import set_curdoc

from beam.discovery.ranking import candidate_effects
from beam.physics.effects import EFFECTS
from dashboard.app import create_app
from dashboard.jobs.beam import load_bundled
from dashboard.state.session import SessionState
from dashboard.views.tabs import VIEWS
from dashboard.views.toy import ToyView


@pytest.fixture
def session(pool):
    s = SessionState(pool=pool, debounce_s=0.0, toy_inputs={"target_ess": 200, "horizon_s": 15.0})
    yield s
    s.close()
    s.wait(10)


def _sources(root, name):
    return [m for m in root.select({"type": ColumnDataSource}) if m.name == name]


def _css_classes(root) -> dict[str, list[str]]:
    return {m.id: list(m.css_classes) for m in root.references() if hasattr(m, "css_classes")}


def test_app_has_three_views_over_one_session(session):
    doc = Document()
    with set_curdoc(doc):
        app = create_app(session)
    assert app.session_state is session
    tabs = app.main[0]
    assert [title for title, _ in VIEWS] == ["Toy periodic model", "Beam calibration", "Window study", "Diagnosis", "Your record",
                                           "Several records"]
    assert app.tab_titles == ["Toy periodic model", "Beam calibration", "Window study", "Diagnosis", "Your record",
                                           "Several records"]
    assert list(app.views) == app.tab_titles
    assert all(view.session is session for view in app.views.values())


def test_widget_labels_carry_units(session):
    view = ToyView(session=session)
    names = [w.label for w in view.layout.select(pn.widgets.Widget) if hasattr(w, "value")]
    for label in ("Calibration window (s)", "Discrepancy amplitude δ (du)", "Noise sd (du)", "Horizon (s)"):
        assert label in names
    numbers = [n.label for n in view.layout.select(pn.indicators.Number)]
    assert any("(%)" in n for n in numbers) and any("(du)" in n for n in numbers)


def test_results_flow_into_the_plot_sources(session):
    view = ToyView(session=session)
    root = view.__panel__().get_root(Document())
    band = _sources(root, "prediction-band")
    assert len(band) == 1 and len(band[0].data["upper"]) == 0
    assert not view.sweep_built
    session.toy.request(debounce=False)
    assert session.wait(30)
    assert view.sweep_built and len(view.sweep_tab) == 2  # sweep plots built when the sweep arrived
    result = session.toy.result
    assert list(band[0].data["upper"]) == list(result.bands.prediction_upper)
    assert len(band[0].data["time_s"]) == result.data.time_s.size
    before = list(band[0].data["upper"])
    classes = _css_classes(root)
    session.toy.window_s = 9.0
    assert session.wait(30)
    assert list(band[0].data["upper"]) != before
    assert view.timeseries.window.right == 9.0
    # a new result changes data and texts, not CSS classes (each costs the browser a re-layout)
    assert {k: v for k, v in _css_classes(root).items() if k in classes} == classes


def test_corner_plot_is_built_when_its_tab_opens(session):
    view = ToyView(session=session)
    session.toy.request(debounce=False)
    assert session.wait(30)
    assert view.corner is None
    view.result_tabs.active = 1
    corner = view.corner
    assert corner is not None
    assert len(corner.sources[("frequency_Hz", "current")].data["top"]) == 30
    assert corner.spans["frequency_Hz"].visible
    session.toy.pin()
    assert len(corner.sources[("amplitude", "frequency_Hz", "pinned")].data["x"]) == 500


def test_error_alert_shows_and_hides(session):
    view = ToyView(session=session)
    alert = view.layout.select(pn.pane.Alert)[0]
    session.toy.request(debounce=False)
    assert session.wait(30)
    session.toy.param.update(horizon_s=10.0, window_s=12.0)
    assert session.wait(30)
    assert alert.visible and "horizon" in alert.object
    session.toy.window_s = 5.0
    assert session.wait(30)
    assert not alert.visible


@pytest.fixture
def beam_session(pool):
    s = SessionState(pool=pool, debounce_s=0.0, beam_inputs={"target_ess": 200})
    yield s
    s.close()
    s.wait(30)


def test_beam_view_labels_carry_units_and_results_reach_the_plot(beam_session):
    from dashboard.views.beam import BeamCalibrationView

    session = beam_session
    view = BeamCalibrationView(session=session)
    assert not view.built  # built when its tab is opened
    view.build()
    root = view.__panel__().get_root(Document())
    labels = [getattr(w, "label", "") for w in view.layout.select(pn.widgets.Widget)]
    assert "Calibration window (s)" in labels and "Number of modes" in labels  # no "(1)": a count has no unit
    readouts = view.layout.select(lambda o: "beam-cal-readouts" in getattr(o, "css_classes", []))[0]
    assert readouts.object.count(" µm</span>") == 3 and " %</span>" in readouts.object
    band = _sources(root, "beam-prediction-band")
    assert len(band) == 1 and len(band[0].data["upper"]) == 0
    view.activate()
    assert session.wait(60)
    result = session.beam.result
    assert not result.is_preview and len(band[0].data["upper"]) == result.bands.time_s.size
    assert view.plot.window.right == pytest.approx(1.05)
    view.result_tabs.active = 1  # the pair plot is built when its tab opens
    assert view.corner is not None and len(view.corner.sources[("bending_stiffness_Nm2", "current")].data["top"]) == 30
    # the printable summary of the view: self-contained, with the judged read-outs in words
    from dashboard.outputs import beam as bs

    text = bs.summary_html(result).getvalue().decode("utf-8")
    assert "://" not in text and "src=" not in text and "href=" not in text and "<script" not in text
    for item in bs.judged_readouts(result):
        if item["words"]:
            assert f"{item['label']}: {item['value']} {item['unit']}" in text
    assert "Air damping, Kelvin–Voigt damping" in text and text.count("<svg") == 1



def test_upload_card_reassembles_the_pieces_and_loads_both_files(beam_session):
    """The upload widget delivers a file in pieces (as the browser sends them); the Load button is
    enabled once both files are complete and loads exactly the uploaded bytes."""
    from panel.models.file_dropper import UploadEvent

    from dashboard.views.beam import BeamCalibrationView

    session = beam_session
    view = BeamCalibrationView(session=session)
    view.build()

    def widget(css):
        return view.layout.select(lambda o: css in getattr(o, "css_classes", []))[0]

    csv, toml, load = widget("beam-upload-csv"), widget("beam-upload-toml"), widget("beam-upload-load")
    assert isinstance(csv, pn.widgets.FileDropper) and load.disabled
    assets = Path(__file__).resolve().parents[2] / "assets" / "measurements"
    data = (assets / "lab_run_5.csv").read_bytes()
    pieces = [data[i:i + 30_000] for i in range(0, len(data), 30_000)]
    assert len(pieces) == 3
    for number, piece in enumerate(pieces, 1):
        assert load.disabled
        csv._process_event(UploadEvent(None, data={"name": "mine.csv", "chunk": number, "total_chunks": len(pieces),
                                                   "data": piece, "type": "text/csv"}))
    assert csv.value["mine.csv"] == data.decode("utf-8") and load.disabled  # text/* arrives decoded
    toml._process_event(UploadEvent(None, data={"name": "mine.toml", "chunk": 1, "total_chunks": 1, "type": "",
                                                "data": (assets / "lab_run_5.toml").read_bytes()}))
    assert not load.disabled
    load.clicks += 1
    beam = session.beam
    assert beam.error == "" and beam.dataset.startswith("upload-1-mine")
    bundled = load_bundled("lab_run_5")  # the same files read from disk
    assert beam.measurement.name == "mine" and beam.measurement.time_s.size == bundled.time_s.size
    assert np.array_equal(beam.measurement.displacement_m, bundled.displacement_m)
    assert np.array_equal(beam.measurement.voltage_V, bundled.voltage_V)
    assert session.wait(60) and beam.result.setup.measurement.name == "mine"


def test_beam_results_change_no_css_classes(pool):
    """A result (preview or final) changes texts and data, never a model's css_classes: each such
    change costs the browser 0.2-0.3 s of re-layout (the beam preview missed its 0.5 s target)."""
    from dashboard.views.beam import BeamCalibrationView

    # a seed of its own: not the final result another test left in the process-wide cache
    session = SessionState(pool=pool, debounce_s=0.0, beam_inputs={"target_ess": 200, "seed": 11})
    view = BeamCalibrationView(session=session)
    view.build()
    root = view.__panel__().get_root(Document())
    notice = view.layout.select(lambda o: "beam-convergence" in getattr(o, "css_classes", []))[0]
    assert 'data-kind="secondary"' in notice.object and "No result yet" in notice.object
    before = _css_classes(root)
    seen = []
    session.beam.param.watch(lambda e: seen.append((e.new.is_preview, notice.object, _css_classes(root))), "result")
    view.activate()
    assert session.wait(60)
    assert [preview for preview, *_ in seen] == [True, False]  # the preview, then the MCMC posterior
    assert 'data-kind="secondary"' in seen[0][1] and "Preview: the single best fit (MAP)" in seen[0][1]
    converged = session.beam.result.posterior.diagnostics.converged
    assert f'data-kind="{"success" if converged else "warning"}"' in notice.object
    assert ("Converged" if converged else "Not converged") in notice.object
    for *_, classes in seen:
        assert {k: v for k, v in classes.items() if k in before} == before
    session.close()


def test_diagnosis_view_shows_candidates_with_add_buttons(beam_session):
    from dashboard.views.diagnosis import DiagnosisView

    session = beam_session
    view = DiagnosisView(session=session)
    view.__panel__().get_root(Document())
    view.activate()
    assert session.wait(60)
    names = [b.label for b in view.candidates.select(pn.widgets.Button)]
    record = session.beam.measurement  # the candidates that apply to this record (a driven patch beam)
    assert record is not None
    expected = {f"Add {EFFECTS[e].title}" for e in candidate_effects(session.beam.effects, record)}
    assert names[0] == "Add Patch stiffening" and set(names) == expected  # effect titles, not ids
    assert len(view.plots.data["residual"]["r"]) == session.beam.measurement.time_s.size
    assert len(view.plots.data["ladder"]) == 1
    # the same diagnosis again (as each partial stage arrives, a new object): the plots are not re-sent
    import copy

    shown = view.plots.data["residual"]
    view.plots.update(copy.copy(session.diagnosis.diagnosis))
    assert view.plots.data["residual"] is shown
    view.plots.update(None)
    assert len(view.plots.data["residual"]["r"]) == 0


def test_a_diagnosis_changes_the_page_layout_twice(pool, caplog):
    """Over a diagnosis the candidates' rows are put in place twice (when the first stage comes, then
    in rank order); no button is enabled one by one and no legend changes: in the browser each such
    change re-lays out the page and repaints every plot (0.2-1.7 s of chromium's CPU each)."""
    import logging

    from dashboard.views.diagnosis import DiagnosisView

    caplog.set_level(logging.DEBUG, logger="dashboard.runtime.scheduler")
    session = SessionState(pool=pool, debounce_s=0.0, beam_inputs={"target_ess": 200})
    view = DiagnosisView(session=session)
    doc = Document()
    doc.add_root(view.__panel__().get_root(doc))
    events = []
    doc.on_change(lambda e: events.append((type(getattr(e, "model", None)).__name__, getattr(e, "attr", None))))
    view.activate()
    assert session.wait(60)
    children = [m for m, attr in events if attr == "children"]
    assert len(children) <= 3, children  # the page (at once here: nothing is staged without a server) + the rows twice
    assert not [e for e in events if e[1] == "disabled" or e[0] == "Legend"]
    names = [b.label for b in view.candidates.select(pn.widgets.Button)]
    d = session.diagnosis
    assert names, (d.stage, d.status, d.error, d.requested, d.shown, caplog.text[-3000:])  # a dropped update says why
    assert names[0] == "Add Patch stiffening" and not any(b.disabled for b in view.candidates.select(pn.widgets.Button))
    session.close()
    session.wait(30)


def test_sweep_plots_show_the_rows_and_mark_the_window_of_the_final_result(session):
    view = ToyView(session=session)
    session.toy.request(debounce=False)
    assert session.wait(30)
    coverage, rmse = view.sweep_plots
    rows = session.toy.sweep
    assert list(coverage.data["window_s"]) == [r["window_s"] for r in rows]
    assert coverage.data["value"][0] == pytest.approx(100.0 * rows[0]["coverage95_prediction"])
    assert rmse.data["value"][-1] == pytest.approx(rows[-1]["rmse_prediction"])
    assert coverage.data["marker_s"] == session.toy.final.scenario.window_s
    session.toy.window_s = 7.0
    assert session.wait(30)
    assert rmse.data["marker_s"] == 7.0


def test_try_this_presets_set_the_inputs_of_their_step(session):
    from dashboard.views.texts import TOY_STEPS

    view = ToyView(session=session)
    buttons = {b.label: b for b in view.layout.select(pn.widgets.Button) if "beam-preset" in b.css_classes}
    expected = {f"{k}. {label}": settings for k, (_, _, presets) in enumerate(TOY_STEPS, start=1)
                for label, settings in presets}
    assert set(buttons) == set(expected)
    for label, settings in expected.items():
        buttons[label].clicks += 1
        assert {name: getattr(session.toy, name) for name in settings} == settings, label


def test_class_guide_follows_the_record():
    """The simulated lab runs get the class script; a measured record its own set-up, in its unit."""
    from dashboard.jobs.beam import load_bundled
    from dashboard.views.texts import BEAM_GUIDE, beam_guide

    lab = load_bundled("lab_run_1")
    assert beam_guide(lab, simulated=True) == BEAM_GUIDE
    real = beam_guide(load_bundled("adxl_50cm_114655"), simulated=False)
    assert "released and rings down freely" in real and "acceleration (m/s²)" in real
    assert "judged on the error in the calibration window" in real and "piezo" not in real
    forced = beam_guide(lab, simulated=False)  # the same record uploaded: a measured displacement under a patch
    assert "a piezo patch drives the beam" in forced and "displacement (m)" in forced
