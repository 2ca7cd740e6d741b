"""Headless Chromium (Debian's ``chromium`` package) for PDF output and the report browser check."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

from plant.errors import GantryError
from plant.host.interrupts import raise_if_requested

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def chromium() -> str | None:
    """Path of a Chromium executable, or None."""
    return next((p for p in (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")) if p), None)


def _run(args: list[str], what: str) -> None:
    exe = chromium()
    if exe is None:
        raise GantryError(f"{what} needs Chromium (Debian: apt-get install chromium); none found on PATH")
    with tempfile.TemporaryDirectory() as profile:
        proc = subprocess.run([exe, *FLAGS, f"--user-data-dir={profile}", *args], capture_output=True, text=True,
                              timeout=120)
    if proc.returncode != 0:
        raise GantryError(f"{what} failed: chromium exited {proc.returncode}: {proc.stderr.strip()[-300:]}")


def html_to_pdf(html: str) -> bytes:
    """The PDF Chromium prints of an HTML document (both kept in a temporary directory, never beside the
    outputs)."""
    with tempfile.TemporaryDirectory() as work:
        page, pdf = Path(work) / "report.html", Path(work) / "report.pdf"
        page.write_text(html, encoding="utf-8")
        _run([f"--print-to-pdf={pdf}", "--no-pdf-header-footer", page.as_uri()], "PDF output")
        raise_if_requested()
        if not pdf.is_file():
            raise GantryError("PDF output failed: chromium wrote no PDF")
        return pdf.read_bytes()


def screenshot(html_path: Path, png_path: Path, *, width: int = 1200, height: int = 3000) -> None:
    """Render an HTML file to a PNG screenshot."""
    _run([f"--screenshot={png_path}", f"--window-size={width},{height}", html_path.resolve().as_uri()], "screenshot")


def dom(html_path: Path) -> str:
    """The document after rendering (``--dump-dom``)."""
    exe = chromium()
    if exe is None:
        raise GantryError("dumping the DOM needs Chromium; none found on PATH")
    with tempfile.TemporaryDirectory() as profile:
        proc = subprocess.run([exe, *FLAGS, f"--user-data-dir={profile}", "--dump-dom", html_path.resolve().as_uri()],
                              capture_output=True, text=True, timeout=120)
    if proc.returncode != 0:
        raise GantryError(f"chromium --dump-dom exited {proc.returncode}")
    return proc.stdout
