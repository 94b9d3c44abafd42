"""Writers of record files to each format's published layout, for the reader tests.

* phyphox: its export code (``ExperimentExportSet``, iOS and Android): the names of the
  export set's buffers quoted and joined by the separator, then one row per sample, every
  value in scientific notation with ten significant digits and the variant's decimal mark,
  a missing value as ``""``; the five CSV variants of ``exportTypes``. The zip export holds one
  CSV per export set plus ``meta/device.csv`` and ``meta/time.csv``.
* Physics Toolbox Sensor Suite: ``time,gFx,gFy,gFz,TgF`` (g) or ``time,ax,ay,az,aT`` (m/s²).
* LabVIEW LVM: NI's "Specification of the LabVIEW Measurement File" (tutorial 4139): file
  header, per-segment channel header, ``X_Value`` names line, tab-separated rows.
* TDMS through npTDMS's writer; MATLAB through scipy.io.savemat (v5) and h5py (v7.3 layout:
  HDF5 with a 512-byte user block, arrays stored column-major); NumPy through numpy.save(z).
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

#: phyphox's CSV variants: (separator, decimal mark), in the order of its exportTypes.
PHYPHOX_VARIANTS = ((",", "."), ("\t", "."), (";", "."), ("\t", ","), (";", ","))


def phyphox_number(value: float, decimal: str) -> str:
    """A value as phyphox writes it: ten significant digits, scientific (``1.234567890E-3``)."""
    mantissa, exponent = f"{value:.9E}".split("E")
    return f"{mantissa.replace('.', decimal)}E{int(exponent)}"


def phyphox_csv_text(names: list[str], columns: list[np.ndarray], separator: str, decimal: str) -> str:
    """The text of one phyphox export set (shorter columns padded with ``""``)."""
    lines = [separator.join(f'"{name}"' for name in names)]
    longest = max(len(c) for c in columns)
    for k in range(longest):
        cells = [phyphox_number(float(c[k]), decimal) if k < len(c) else '""' for c in columns]
        lines.append(separator.join(cells))
    return "\n".join(lines)


def write_phyphox_csv(path: Path, time_s, axes: dict[str, np.ndarray], separator: str = ",", decimal: str = ".",
                      with_g: bool = False) -> Path:
    """A phyphox "Acceleration (without g)" or "Acceleration with g" raw-data export (m/s²)."""
    prefix = "Acceleration" if with_g else "Linear Acceleration"
    names = ["Time (s)"] + [f"{prefix} {axis} (m/s^2)" for axis in axes] + ["Absolute acceleration (m/s^2)"]
    stacked = np.vstack(list(axes.values()))
    columns = [np.asarray(time_s)] + list(axes.values()) + [np.sqrt(np.sum(stacked**2, axis=0))]
    path.write_text(phyphox_csv_text(names, columns, separator, decimal), encoding="utf-8")
    return path


def write_phyphox_zip(path: Path, time_s, axes: dict[str, np.ndarray], separator: str = ",", decimal: str = ".") -> Path:
    """phyphox's zip export: ``Raw Data.csv`` plus ``meta/device.csv`` and ``meta/time.csv``."""
    csv_path = path.with_suffix(".tmp.csv")
    write_phyphox_csv(csv_path, time_s, axes, separator, decimal, with_g=True)
    text = csv_path.read_text(encoding="utf-8")
    csv_path.unlink()
    device = separator.join(['"property"', '"value"']) + "\n" + separator.join(['"deviceModel"', '"Pixel"'])
    times = separator.join(['"event"', '"experiment time"', '"system time"']) + "\n" + separator.join(
        ['"START"', phyphox_number(0.0, decimal), phyphox_number(1.7e9, decimal)])
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("Raw Data.csv", text)
        archive.writestr("meta/device.csv", device)
        archive.writestr("meta/time.csv", times)
    return path


def write_physics_toolbox(path: Path, time_s, axes: dict[str, np.ndarray], *, unit: str = "g", separator: str = ",",
                          clock: bool = False) -> Path:
    """Physics Toolbox Sensor Suite: ``time,gFx,gFy,gFz,TgF`` (g) or ``time,ax,ay,az,aT`` (m/s²)."""
    names = (["gFx", "gFy", "gFz", "TgF"] if unit == "g" else ["ax", "ay", "az", "aT"])
    values = [axes[a] for a in ("x", "y", "z")]
    total = np.sqrt(sum(v**2 for v in values))
    rows = [separator.join(["time", *names])]
    decimal = "," if separator == ";" else "."
    for k, t in enumerate(time_s):
        if clock:
            whole = int(t)
            stamp = f"17:{23 + whole // 60:02d}:{whole % 60:02d}:{int(round((t - whole) * 1000)) % 1000:03d}"
        else:
            stamp = f"{t:.6f}".replace(".", decimal)
        cells = [f"{v[k]:.6f}".replace(".", decimal) for v in (*values, total)]
        rows.append(separator.join([stamp, *cells]))
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def write_lvm(path: Path, segments: list[tuple[float, list[str], list[str], np.ndarray]], *, x_columns: str = "One",
              decimal: str = ".") -> Path:
    """An LVM file with the standard header; each segment is (Delta_X, names, unit labels, rows x channels)."""
    sep = "\t"
    lines = ["LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2", "Separator\tTab",
             f"Decimal_Separator\t{decimal}", "Multi_Headings\tNo", f"X_Columns\t{x_columns}", "Time_Pref\tRelative",
             "Operator\tlab", "Date\t2026/11/26", "Time\t10:00:00.000", "***End_of_Header***", ""]

    def number(value: float) -> str:
        return f"{value:.6f}".replace(".", decimal)

    for delta, names, units, data in segments:
        count = len(names)
        lines += [f"Channels\t{count}\t", "Samples\t" + sep.join([str(data.shape[0])] * count) + sep,
                  "Date\t" + sep.join(["2026/11/26"] * count) + sep, "Time\t" + sep.join(["10:00:00"] * count) + sep,
                  "Y_Unit_Label\t" + sep.join(units) + sep, "X_Dimension\t" + sep.join(["Time"] * count) + sep,
                  "X0\t" + sep.join([number(0.0)] * count) + sep, "Delta_X\t" + sep.join([number(delta)] * count) + sep,
                  "***End_of_Header***\t"]
        lines.append(sep.join(["X_Value", *names, "Comment"]))  # with X_Columns No the X cell stays empty
        for k, row in enumerate(data):
            cells = [number(k * delta) if x_columns == "One" else ""] + [number(v) for v in row]
            lines.append(sep.join(cells))
        lines.append("")
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def write_headerless_lvm(path: Path, time_s, values) -> Path:
    """LabVIEW's headerless two-column tab text (Write To Spreadsheet File)."""
    rows = "\n".join(f"{t:.6f}\t{v:.6f}" for t, v in zip(time_s, values))
    path.write_text(rows + "\n", encoding="utf-8")
    return path


def write_tdms(path: Path, group: str, channels: dict[str, tuple[np.ndarray, str]], increment: float) -> Path:
    """A TDMS file with one group of waveform channels (``unit_string``, ``wf_increment``)."""
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    with TdmsWriter(str(path)) as writer:
        objects = [GroupObject(group)]
        for name, (values, unit) in channels.items():
            objects.append(ChannelObject(group, name, np.asarray(values, dtype=float),
                                         properties={"unit_string": unit, "wf_increment": increment,
                                                     "wf_start_offset": 0.0}))
        writer.write_segment(objects)
    return path


def write_mat73(path: Path, arrays: dict[str, np.ndarray]) -> Path:
    """A MATLAB v7.3 file's layout: HDF5 with a 512-byte user block, arrays column-major."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as handle:
        for name, value in arrays.items():
            data = np.asarray(value, dtype=float)
            handle.create_dataset(name, data=data.reshape(1, -1) if data.ndim == 1 else data.T)
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Nov 26 10:00:00 2026 HDF5 schema 1.00 ."
    with open(path, "r+b") as handle:
        handle.write(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")
    return path


#: The real record re-saved in every format (assets/real/formats), and how much of it (s).
REAL_SOURCE = "adxl_50cm_114655"
REAL_EXCERPT_S = 1.5


def write_real_formats(source_csv: Path, folder: Path, seconds: float = REAL_EXCERPT_S) -> dict[str, Path]:
    """The first ``seconds`` of a bundled real record (``time_s,acceleration_m_s2``) re-saved in
    every format, each to its layout above; returns format name -> file. The acceleration is
    written in g where the format's apps write g (Physics Toolbox, the LVM and TDMS channels),
    in m/s² otherwise. Physics Toolbox's x and y columns are zeros (the record has one axis)."""
    import scipy.io

    table = np.loadtxt(source_csv, delimiter=",", skiprows=1)
    table = table[table[:, 0] < table[0, 0] + seconds]
    t, a = table[:, 0], table[:, 1]
    g = a / 9.80665
    folder.mkdir(parents=True, exist_ok=True)
    stem = source_csv.stem
    files = {
        "phyphox": write_phyphox_csv(folder / f"{stem}.phyphox.csv", t, {"z": a}, ";", ",", with_g=True),
        "physics-toolbox": write_physics_toolbox(folder / f"{stem}.physics_toolbox.csv", t,
                                                 {"x": 0 * g, "y": 0 * g, "z": g}, unit="g"),
        "lvm": _write_lvm_with_time(folder / f"{stem}.lvm", t, g),
        "headerless-lvm": write_headerless_lvm(folder / f"{stem}.headerless.lvm", t, a),
        "tdms": _write_tdms_with_time(folder / f"{stem}.tdms", t, g),
        "npy": folder / f"{stem}.npy",
        "npz": folder / f"{stem}.npz",
        "mat": folder / f"{stem}.mat",
        "mat73": write_mat73(folder / f"{stem}.v73.mat", {"t": t, "acc_z_m_s2": a}),
    }
    np.save(files["npy"], np.c_[t, a])
    np.savez(files["npz"], time_s=t, acceleration_m_s2=a)
    scipy.io.savemat(files["mat"], {"adxl": {"t": t, "acc_z_g": g}})
    return files


def _write_lvm_with_time(path: Path, t: np.ndarray, g: np.ndarray) -> Path:
    """An LVM (standard header) whose X_Value column holds the record's own irregular stamps."""
    write_lvm(path, [(float(np.median(np.diff(t))), ["ADXL357 Z"], ["g"], np.c_[g])])
    lines = path.read_text(encoding="utf-8").split("\n")
    start = next(k for k, line in enumerate(lines) if line.startswith("X_Value")) + 1
    for k in range(t.size):
        cells = lines[start + k].split("\t")
        cells[0] = f"{t[k]:.6f}"
        lines[start + k] = "\t".join(cells)
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _write_tdms_with_time(path: Path, t: np.ndarray, g: np.ndarray) -> Path:
    """A TDMS group with a time channel (s) and the acceleration (g): irregular stamps."""
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    with TdmsWriter(str(path)) as writer:
        writer.write_segment([GroupObject("ADXL357"),
                              ChannelObject("ADXL357", "Time", t, properties={"unit_string": "s"}),
                              ChannelObject("ADXL357", "Acceleration Z", g, properties={"unit_string": "g"})])
    return path
