"""The PDF report is the HTML report on A4 or Letter pages (issue 32 item 6), checked as a person would look at it:
its pages rendered by pdftoppm, its text read by pdftotext."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from gasfilm.analysis import report
from gasfilm.analysis.report import default_paper, write_report
from test_cli_acquire_replay import FAST_SIM

pytestmark = pytest.mark.skipif(shutil.which("pdftoppm") is None, reason="pdftoppm (poppler-utils) is not installed: "
                                "./run test installs it")

#: Page sizes in points (1/72 in): what pdftoppm renders at 72 dpi, in pixels.
A4_PT, LETTER_PT = (595, 842), (612, 792)


@pytest.fixture(scope="module")
def fitted_session(tmp_path_factory):
    from gasfilm.app.cli import main

    path = tmp_path_factory.mktemp("pdf") / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "4", "--seed", "5", "--operator", "A. Tester",
                 "--test-object", "mover M2", "--condition", "supply_pressure_mpa=0.4"]) == 0
    assert main(["fit", str(path), "--models", "SD", "--out", str(path.parent / "fit")]) == 0
    return path


def pages(pdf, dpi: int = 72) -> list[np.ndarray]:
    prefix = pdf.with_suffix("")
    subprocess.run(["pdftoppm", "-r", str(dpi), "-png", str(pdf), str(prefix)], check=True)
    return [np.asarray(Image.open(page).convert("RGB")) for page in sorted(pdf.parent.glob(f"{prefix.name}-*.png"))]


def test_the_pdf_is_the_html_report_with_its_figures_and_tables_on_a4_or_letter(fitted_session, tmp_path):
    a4 = write_report(fitted_session, tmp_path / "a4.pdf", paper="a4")
    a4_pages = pages(a4)
    assert len(a4_pages) >= 3
    for page in a4_pages:
        assert abs(page.shape[1] - A4_PT[0]) <= 1 and abs(page.shape[0] - A4_PT[1]) <= 1
    # nothing is cut at the margin: the right-hand 8 mm of every page (above the page number) stay white
    for page in a4_pages:
        margin = page[: -int(16 / 25.4 * 72), -int(8 / 25.4 * 72):]
        assert margin.min() >= 250, "something runs into the right margin"
    # the figures are there: pages with the curves' colours (the coherence green, the force spectrum blue)
    coloured = [int(np.count_nonzero((np.ptp(page.astype(int), axis=2) > 60))) for page in pages(a4, 50)]
    assert sum(count > 400 for count in coloured) >= 2, coloured
    text = subprocess.run(["pdftotext", "-layout", str(a4), "-"], capture_output=True, text=True, check=True).stdout
    for words in ("gasfilm session report", "Operator A. Tester", "mover M2", "supply_pressure_mpa",
                  "Hits: 4 accepted of 4", "Identified models (Table 2)", "Parameters (count)",
                  "Identified parameters", "±1σ", "N/m", "N·s/m", "Trigger level (N)", "page 1 of",
                  "Control design"):
        assert words in text, words
    html = write_report(fitted_session, tmp_path / "same.html").read_text(encoding="utf-8")
    assert "Identified parameters" in html and "@page { size: " in html  # one report, printed as it is shown


def test_the_paper_follows_the_flag_else_the_machine(monkeypatch, fitted_session, tmp_path, capsys):
    from gasfilm.app.cli import main

    monkeypatch.setenv("PAPERSIZE", "letter")
    assert default_paper() == "letter"
    monkeypatch.setenv("PAPERSIZE", "")
    monkeypatch.setattr(report, "Path", lambda *_: tmp_path / "no-papersize-file")
    monkeypatch.delenv("LC_ALL", raising=False)
    monkeypatch.delenv("LC_PAPER", raising=False)
    monkeypatch.setenv("LANG", "en_US.UTF-8")
    assert default_paper() == "letter"
    monkeypatch.setenv("LANG", "de_DE.UTF-8")
    assert default_paper() == "a4"
    monkeypatch.setenv("LC_PAPER", "en_CA.UTF-8")
    assert default_paper() == "letter"
    monkeypatch.undo()
    assert main(["report", str(fitted_session), "--out", str(tmp_path / "r.pdf"), "--paper", "letter"]) == 0
    for page in pages(tmp_path / "r.pdf"):
        assert abs(page.shape[1] - LETTER_PT[0]) <= 1 and abs(page.shape[0] - LETTER_PT[1]) <= 1
        assert page[: -int(16 / 25.4 * 72), -int(8 / 25.4 * 72):].min() >= 250
