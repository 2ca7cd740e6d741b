"""The specs bundled with the tool (``specs/`` of the checkout, installed as ``design/specs``), and reading a spec
file with a hint when the one named is missing but a bundled one has its name (a user outside the checkout
typing ``gantry synth stage_x_synth.toml``)."""

from __future__ import annotations

from pathlib import Path

from plant.errors import DataError, SpecError
from plant.host.text_io import read_text

BUNDLED_DIR = Path(__file__).resolve().parents[1] / "specs"


def bundled_spec(name: str) -> Path:
    """The bundled spec ``name``; ``SpecError`` when the package was installed without it."""
    path = BUNDLED_DIR / name
    if not path.is_file():
        raise SpecError(f"bundled spec {name} is not installed with the package (looked in {BUNDLED_DIR}); "
                        "pass --spec FILE")
    return path


def read_spec_text(path: str | Path) -> str:
    """The text of the spec file ``path`` (``plant.host.text_io.read_text``); when it does not exist and a bundled
    spec has its name, the error says where that one is."""
    path = Path(path)
    try:
        return read_text(path, what="spec file")
    except DataError as exc:
        bundled = BUNDLED_DIR / path.name
        if path.exists() or not bundled.is_file() or bundled.resolve() == path.resolve():
            raise
        raise SpecError(f"{exc}; a spec of that name is bundled with the tool: {bundled}") from None
