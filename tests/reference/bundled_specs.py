"""The bundled admittance spec as a test copies it elsewhere: its force record (a path relative to ``specs/``) made
absolute, so a copy in a temporary folder still finds it."""

import tomllib
from pathlib import Path

SPEC = Path(__file__).resolve().parents[2] / "specs" / "stage_x_admittance.toml"
RECORD_LINE = 'force_record = "../examples/data/lab_mouse_track.csv"'


def admittance_text() -> str:
    text = SPEC.read_text()
    assert RECORD_LINE in text
    absolute = (SPEC.parent / "../examples/data/lab_mouse_track.csv").resolve().as_posix()
    return text.replace(RECORD_LINE, f'force_record = "{absolute}"', 1)


def admittance_data() -> dict:
    return tomllib.loads(admittance_text())
