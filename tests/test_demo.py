"""The README's first command: a short simulated hammer session, summarised, with its session file."""

import numpy as np

from gasfilm.analysis.session import Session
from gasfilm.app.cli import main


def test_demo_prints_hits_peak_force_and_response_and_stores_the_session(tmp_path, capsys):
    out = tmp_path / "demo.h5"
    assert main(["demo", "--hits", "3", "--out", str(out), "--no-fit"]) == 0
    printed = capsys.readouterr().out
    assert "hits seen:" in printed and "peak force:" in printed and "peak response:" in printed
    with Session.open(out) as session:
        records = session.accepted_records()
        frf = session.read_frf()
    assert records.shape[0] == 3
    band = (frf.freq_hz > 150) & (frf.freq_hz < 250)
    peak_hz = frf.freq_hz[band][np.argmax(np.abs(frf.h1[band]))]
    assert abs(peak_hz - 199.0) < 4.0  # the FOMGF film of Table 1 on 25.05 kg resonates near 199 Hz
