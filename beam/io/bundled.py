"""Records bundled with the project, found by name from the command line and the dashboard alike.

The bundled lab runs live in ``assets/measurements`` and the real records in ``assets/real``
(each ``NAME.csv`` + ``NAME.toml``) when the package is used from the repository checkout.
"""

from __future__ import annotations

from pathlib import Path

#: The project's assets (empty folders when the package is installed without them).
ASSETS = Path(__file__).resolve().parents[2] / "assets"
#: Folders searched for a bundled record, in order.
BUNDLED_FOLDERS: tuple[Path, ...] = (ASSETS / "measurements", ASSETS / "real")


def bundled_path(name: str) -> Path | None:
    """``FOLDER/NAME.csv`` of the bundled record ``name`` (a bare name, ``.csv`` optional), None if none."""
    stem = name[:-4] if name.lower().endswith(".csv") else name
    if not stem or "/" in stem or "\\" in stem:
        return None
    for folder in BUNDLED_FOLDERS:
        candidate = folder / f"{stem}.csv"
        if candidate.is_file():
            return candidate
    return None


def bundled_record_names() -> list[str]:
    """Names of every bundled record (lab runs, then real records), sorted within each folder."""
    names: list[str] = []
    for folder in BUNDLED_FOLDERS:
        if folder.is_dir():
            names += sorted(p.stem for p in folder.glob("*.csv"))
    return names


def resolve_data_path(text: str) -> str:
    """A record path as given, or the bundled record of that name.

    A bare name (no directory part) that is neither a file here nor ``NAME.csv`` here is looked
    up among the bundled records: ``lab_run_1`` and ``adxl_50cm_114655`` are found from
    anywhere. Anything else is returned unchanged (a missing file is reported by the reader).
    """
    path = Path(text)
    stem = path.with_suffix("") if path.suffix.lower() in (".csv", ".toml") else path
    if path.parent != Path(".") or not path.name or path.exists() or stem.with_name(stem.name + ".csv").exists():
        return text
    bundled = bundled_path(stem.name)
    return str(bundled) if bundled is not None else text
