"""The catalogue is the one place that names an effect, and the kind of record is told once.

An AST scan of ``beam/`` and ``dashboard/``:

* every effect id and parameter name (a string constant equal to one, or a keyword argument
  named by one) appears only in its own module under ``beam/physics/effects/`` (the base's, EI
  and k_p, in ``base.py``; a per-mode family's prefix in its effect's module), and the default
  model's effect ids in ``beam/calibration/defaults.py``; the sidecar readers
  (:data:`SIDECAR_READERS`) read the documented ``[nominal]`` keys by their names;
* ``.is_free`` is read at most twice in ``beam/calibration/`` (where the calibration model is
  chosen, and where the number of modes of a free response is);
* no ``getattr(model, "name", ...)`` / ``hasattr`` asks a model (an expression naming one) for an
  optional hook in ``beam/calibration/`` or ``beam/inference/``.
"""

from __future__ import annotations

import ast
import os
from pathlib import Path

from beam.physics.effects import BASE_PARAMETERS, EFFECTS

ROOT = Path(__file__).resolve().parents[1]
EFFECTS_DIR = "beam/physics/effects"
#: Modules that read a sidecar's documented keys ([nominal] bending_stiffness_Nm2, sensor_mass_kg, ...).
SIDECAR_READERS = {"beam/io/config.py", "beam/io/measurement.py"}
DEFAULTS = "beam/calibration/defaults.py"
#: Hooks a model was asked for by name (the pipeline's calibration models carry them now).
HOOK_READERS = ("beam/calibration", "beam/inference")


def owners() -> tuple[dict[str, str], dict[str, str]]:
    """(name -> the module that may write it, family prefix -> its module)."""
    owner = {p.name: f"{EFFECTS_DIR}/base.py" for p in BASE_PARAMETERS}
    prefixes = {}
    for effect in EFFECTS.values():
        module = f"{EFFECTS_DIR}/{effect.id}.py"
        owner[effect.id] = module
        for name in effect.parameter_names:
            owner[name] = module
        if effect.per_mode:
            prefixes[os.path.commonprefix(effect.parameter_names).rstrip("0123456789")] = module
    return owner, prefixes


def named(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, text) of every string constant and keyword argument name in ``tree``."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            out.append((node.lineno, node.value))
        elif isinstance(node, ast.keyword) and node.arg is not None:
            out.append((node.value.lineno, node.arg))
    return out


def stray_literals(path: str, source: str, owner: dict[str, str], prefixes: dict[str, str]) -> list[str]:
    """The effect ids and parameter names ``source`` (the module at ``path``) writes that are not its own."""
    if path in SIDECAR_READERS:
        return []
    defaults = set(EFFECTS) if path == DEFAULTS else set()
    bad = []
    for line, text in named(ast.parse(source)):
        home = owner.get(text)
        if home is None:
            home = next((m for p, m in prefixes.items() if text.startswith(p) and text[len(p):].isdigit() or text == p),
                        None)
        if home is not None and home != path and text not in defaults:
            bad.append(f"{path}:{line}: {text!r} (its home: {home})")
    return bad


def sources(*tops: str) -> list[tuple[str, str]]:
    return [(p.relative_to(ROOT).as_posix(), p.read_text(encoding="utf-8"))
            for top in tops for p in sorted((ROOT / top).rglob("*.py"))]


def test_effect_ids_and_parameter_names_are_written_only_in_their_own_modules():
    owner, prefixes = owners()
    bad = [b for path, source in sources("beam", "dashboard") for b in stray_literals(path, source, owner, prefixes)]
    assert bad == []


def test_the_literal_check_sees_a_stray_name_and_leaves_an_effects_own():
    """The check itself, on made-up sources: an id, a parameter name, a keyword and a per-mode
    name outside their modules are found; the same in their own module, or in prose, are not."""
    owner, prefixes = owners()
    stray = 'x = "tip_mass"\ny = values["drag_coefficient"]\nz = dict(tip_mass_kg=1.0)\nw = "damping_ratio_mode_3"\n'
    assert len(stray_literals("beam/discovery/x.py", stray, owner, prefixes)) == 4
    assert stray_literals(f"{EFFECTS_DIR}/tip_mass.py", 'x = "tip_mass"\nz = dict(tip_mass_kg=1.0)\n', owner,
                          prefixes) == []
    assert stray_literals("beam/discovery/x.py", '"""the tip_mass effect, named in prose"""\n', owner, prefixes) == []
    assert stray_literals(DEFAULTS, 'DEFAULT = ("air_damping",)\n', owner, prefixes) == []


def attribute_reads(source: str, name: str) -> int:
    return sum(isinstance(n, ast.Attribute) and n.attr == name for n in ast.walk(ast.parse(source)))


def test_the_kind_of_record_is_told_at_most_twice_in_the_calibration():
    reads = {path: attribute_reads(source, "is_free") for path, source in sources("beam/calibration")}
    assert sum(reads.values()) <= 2, {p: n for p, n in reads.items() if n}


def test_no_model_is_asked_for_a_hook_by_name():
    hooks = []
    for path, source in sources(*HOOK_READERS):
        for node in ast.walk(ast.parse(source)):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr")
                    and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant)
                    and "model" in ast.unparse(node.args[0])):
                hooks.append(f"{path}:{node.lineno}: {ast.unparse(node)}")
    assert hooks == []
