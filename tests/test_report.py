"""``gasfilm report``: a self-contained HTML (or PDF) report of a real session file, never replacing a file unasked."""

import base64
import re

import numpy as np
import pytest

from gasfilm.analysis.spectra import force_level_db, usable_band_hz
from gasfilm.analysis.session import Session
from gasfilm.app.cli import main


@pytest.fixture(scope="module")
def session_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("report") / "demo.h5"
    assert main(["demo", "--hits", "3", "--out", str(path), "--seed", "4"]) == 0  # simulated hits, SD and FOMGF fits
    return path


def test_report_holds_setup_hits_frf_force_spectrum_and_fits(session_path, tmp_path, capsys):
    out = tmp_path / "report.html"
    assert main(["report", str(session_path), "--out", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    text = out.read_text(encoding="utf-8")
    images = re.findall(r"src='data:image/png;base64,([A-Za-z0-9+/=]+)'", text)
    assert len(images) == 4  # hits overlay, FRF with coherence and force spectrum, fitted models, rational model error
    assert all(base64.b64decode(image)[:8] == b"\x89PNG\r\n\x1a\n" for image in images)
    assert "http" not in text.replace("http-equiv", "")  # self-contained: nothing fetched from elsewhere
    with Session.open(session_path) as session:
        hits = session.hit_count
        accepted = len(session.accepted_indices())
        fits = session.result_names("fits")
    assert f"Hits: {accepted} accepted of {hits}" in text
    assert "11.2 mV/N" in text and "Peak force (N)" in text and "Time (s)" in text
    assert "Usable band (force spectrum within 20 dB" in text and " Hz" in text
    for name in fits:
        assert f"<td>{name}</td>" in text
    assert "RMS (g/N)" in text and "No diagnosis stored" in text


def test_report_never_replaces_a_file_unless_asked(session_path, tmp_path, capsys):
    out = tmp_path / "kept.html"
    out.write_text("the engineer's notes")
    assert main(["report", str(session_path), "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--out" in error and "--overwrite" in error
    assert out.read_text() == "the engineer's notes"

    target = tmp_path / "target.txt"
    target.write_text("do not touch")
    link = tmp_path / "link.html"
    link.symlink_to(target)
    assert main(["report", str(session_path), "--out", str(link)]) == 2
    assert target.read_text() == "do not touch"
    assert main(["report", str(session_path), "--out", str(link), "--overwrite"]) == 0
    assert link.is_symlink() and target.read_text().startswith("<!DOCTYPE html>")  # written where the link points

    assert main(["report", str(session_path), "--out", str(out), "--overwrite"]) == 0
    assert out.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert main(["report", str(session_path), "--out", str(tmp_path / "report.docx")]) == 2
    assert main(["report", str(tmp_path / "missing.h5"), "--out", str(tmp_path / "r.html")]) == 2
    assert "missing.h5" in capsys.readouterr().err and not (tmp_path / "r.html").exists()


def test_pdf_report(session_path, tmp_path):
    out = tmp_path / "report.pdf"
    assert main(["report", str(session_path), "--out", str(out)]) == 0
    assert out.read_bytes()[:5] == b"%PDF-" and out.stat().st_size > 20_000


def test_usable_band_ends_where_a_half_sine_pulse_falls_20_db():
    sample_rate_hz, pulse_s = 12800.0, 1e-3
    t = np.arange(6400) / sample_rate_hz
    force = np.where(t < pulse_s, np.sin(np.pi * t / pulse_s), 0.0)
    freq = np.fft.rfftfreq(t.size, 1 / sample_rate_hz)
    gff = np.abs(np.fft.rfft(force)) ** 2
    level = force_level_db(freq, gff)
    assert np.isnan(level[0]) and abs(level[1]) < 0.1
    low, high = usable_band_hz(freq, gff, 20.0)
    assert low == freq[1]
    assert level[freq == high][0] < -20.0 and np.all(level[1 : np.flatnonzero(freq == high)[0]] >= -20.0)
    first_null_hz = 1.5 / pulse_s
    assert 0.7 * first_null_hz < high < first_null_hz  # before the pulse's first spectral null
    assert usable_band_hz(freq, gff, 10.0)[1] < high
