"""``beam import FILE``: read a record in any supported format, describe its beam, write the
project's own ``PREFIX.csv`` + ``PREFIX.toml`` and say what was read.

The summary lists the file's columns, the signal used and why, the sampling rate, duration and
clipping, the plucks found, and the record's first spectral peaks beside the ideal beam's
modes (the bare beam of the given geometry at the nominal bending stiffness, with the sensor's
mass when given), so that a wrong geometry shows at once.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from beam.cli.arguments import HelpFormatter
from beam.cli.record_arguments import add_record_arguments, beam_document, measurement_from_args

#: Spectral peaks and model modes listed.
LISTED_PEAKS = 6


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``import`` subcommand."""
    parser = subparsers.add_parser(
        "import",
        help="read a record from a phone app, LabVIEW, a DAQ or MATLAB and write it as NAME.csv + NAME.toml",
        description="Read FILE (phyphox CSV or zip, Physics Toolbox CSV, LabVIEW .lvm, NI .tdms, MATLAB .mat, "
        "NumPy .npy/.npz, any CSV/TSV/whitespace text), describe the beam with the flags, write PREFIX.csv + "
        "PREFIX.toml and print what was read with the record's spectral peaks beside the ideal beam's modes.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("data", metavar="FILE", help="the record file")
    parser.add_argument("--out", default=None, metavar="PREFIX",
                        help="write PREFIX.csv and PREFIX.toml (default: FILE's name + '_beam', next to it)")
    add_record_arguments(parser)
    parser.set_defaults(func=run)


def output_prefix(data: str, out: str | None) -> Path:
    """``PREFIX`` for the files written (never the input file itself)."""
    source = Path(data)
    prefix = Path(out) if out else source.with_name(source.stem + "_beam")
    if prefix.suffix.lower() in (".csv", ".toml"):
        prefix = prefix.with_suffix("")
    return prefix


def run(args: argparse.Namespace) -> int:
    from beam.errors import BeamInputError
    from beam.io.measurement import measurement_csv_text
    from beam.io.text import atomic_write_texts, dump_toml

    document, measurement, summary = summarise(args)
    prefix = output_prefix(args.data, args.out)
    csv_path, toml_path = prefix.with_name(prefix.name + ".csv"), prefix.with_name(prefix.name + ".toml")
    if Path(args.data).resolve() in (csv_path.resolve(), toml_path.resolve()):
        raise BeamInputError(f"--out {prefix}: would overwrite the record {args.data}; choose another PREFIX")
    sys.stdout.write(summary)  # the summary first: writing 80,000 rows at full precision takes longer
    sys.stdout.flush()
    columns = measurement.columns
    sidecar = {"title": document.get("title") or f"{Path(args.data).name}, imported"}
    sidecar.update({key: value for key, value in document.items() if key != "title"})
    if measurement.arbitrary_units:  # the project's CSV names the quantity; the sidecar says its scale is unknown
        sidecar["sensor"] = {**sidecar.get("sensor", {}), "unit": "arbitrary"}
    atomic_write_texts({
        csv_path: measurement_csv_text(*(getattr(measurement, c) for c in columns), names=columns),
        toml_path: dump_toml(sidecar, header_comment=f"The beam of {Path(args.data).name}, as described to beam import."),
    })
    sys.stdout.write("".join(f"written: {path}\n" for path in (csv_path, toml_path)))
    return 0


def summarise(args: argparse.Namespace):
    """(sidecar document, measurement, summary text) of ``beam import``'s arguments."""
    from beam.errors import BeamInputError

    document = beam_document(args, default_sensor_at_tip=True)
    if document is None:
        raise BeamInputError("beam import: describe the beam: --length, --width, --thickness and --material "
                             "(or --youngs-modulus and --density), or --beam BEAM.toml")
    measurement = measurement_from_args(args, default_sensor_at_tip=True)
    return document, measurement, format_import(measurement)


def ideal_modes_Hz(measurement, count: int = LISTED_PEAKS) -> list[float]:
    """The ideal (bare) beam's first natural frequencies (Hz) at the nominal bending stiffness,
    with the sensor's mass when the description gives it; empty without a nominal stiffness."""
    from beam.physics.effects import sensor_mass
    from beam.physics.effects.base import BENDING_STIFFNESS
    from beam.physics.model import BeamModel

    stiffness = measurement.nominal.get(BENDING_STIFFNESS.name)
    if stiffness is None:
        return []
    mass = measurement.nominal.get(sensor_mass.MASS.name)
    model = BeamModel(measurement.geometry, (sensor_mass.EFFECT.id,) if mass else (), input_kind=measurement.input_kind)
    parameters = {BENDING_STIFFNESS.name: stiffness, **({sensor_mass.MASS.name: mass} if mass else {})}
    frequencies, _ = model.natural_modes(parameters, min(count, model.size))
    return [float(f) for f in frequencies]


def format_import(measurement) -> str:
    """The summary ``beam import`` prints (module notes)."""
    from beam.io.anchor import spectral_peaks

    geometry = measurement.geometry
    lines = [f"{measurement.name}: {measurement.sample_count:,} samples, {measurement.duration_s:.3f} s at "
             f"{measurement.rate_Hz:.6g} Hz ({'uniform' if measurement.uniform else 'irregular'} stamps, steps "
             f"{measurement.min_interval_s * 1e3:.4g}-{measurement.max_interval_s * 1e3:.4g} ms)"]
    lines += [f"  {line}" for line in measurement.source]
    output = measurement.output
    shown, unit = output, measurement.output_unit
    if measurement.output_kind == "strain" and not measurement.arbitrary_units:
        shown, unit = output * 1e6, "µε"  # read as a gauge shows it; the files keep SI (m/m)
    stays = "gravity and bias stay" if measurement.output_kind == "acceleration" else "the sensor's offset stays"
    lines.append(f"output {measurement.output_column}: {shown.min():.4g} to {shown.max():.4g} {unit}, "
                 f"mean {shown.mean():.4g} ({stays}: the calibration's offset takes {'them' if 'bias' in stays else 'it'}); "
                 f"clipped samples: {measurement.clipped_count}")
    lines.append(f"beam: L = {geometry.length_m:g} m, {geometry.linear_density_kg_m:.4g} kg/m, sensor at "
                 f"{geometry.sensor_position_m:g} m")
    for name, value in measurement.nominal.items():
        origin = measurement.nominal_origin.get(name, "[nominal]")
        spread = measurement.nominal_spread.get(name)
        spread_text = f", prior log-sd {spread:.3g}" if spread is not None else ""
        lines.append(f"nominal {name} = {value:.5g} ({origin}{spread_text})")
    peaks = spectral_peaks(measurement.time_s, output, measurement.output_kind, max_peaks=LISTED_PEAKS)
    modes = ideal_modes_Hz(measurement)
    lines.append("")
    lines.append(f"{'record peak (Hz)':>17s} {'prominence':>11s} {'strong':>7s}   {'ideal beam mode':>16s}")
    for k in range(max(len(peaks), len(modes))):
        peak = peaks[k] if k < len(peaks) else None
        left = (f"{peak.frequency_Hz:17.4g} {peak.prominence_db:9.0f} dB {'yes' if peak.strong else 'no':>7s}"
                if peak else f"{'':17s} {'':11s} {'':7s}")
        right = f"   mode {k + 1}: {modes[k]:8.4g} Hz" if k < len(modes) else ""
        lines.append(left + right)
    return "\n".join(lines) + "\n"
