"""Today's one-accelerometer path in figures: a simulated stream, a session's FRF and fits, a spec's accelerance and
replayed response. ``one-accelerometer.npz`` holds them as gasfilm computed them before the rigid body (issue 34:
main at 6f8e589, and the same bits at 2c8812b), but for the two FOMGF fits, taken again after issue 31 (a fit's arms in
one canonical order, what the data do not determine taken out of it; the all-effects one again when its reduced
form was polished from the fit instead of searched anew: the same RMS to 3e-12, parameters moved along the flat valley
of an order at 1.97 by up to 9e-5): ``python tests/golden/one_accelerometer.py
OUT.npz`` makes the file; the test compares. Only APIs that exist at those commits are used."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

RIGS = Path(__file__).resolve().parents[2] / "fixtures" / "rigs"


def figures() -> dict[str, np.ndarray]:
    from gasfilm.analysis.identification import fit_model
    from gasfilm.analysis.physics.plant import RigPlant
    from gasfilm.analysis.physics.response import rig_accelerance, simulate_response
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.spectra import WindowSettings, compute_frf
    from gasfilm.drivers.interface import ChannelConfig, ChannelKind, DaqConfig, default_hammer_and_accelerometer
    from gasfilm.drivers.simulated import SimulatedNI9234

    rate_hz = 6400.0
    four = DaqConfig(channels=(ChannelConfig("ai0", ChannelKind.FORCE, 11.2, "mV/N"),
                               *(ChannelConfig(f"ai{i}", ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)")
                                 for i in (1, 2, 3))), sample_rate_hz=rate_hz)
    out = {}
    for label, spec in (("fomgf", RigSpec.nominal("FOMGF")), ("effects", RigSpec.load(RIGS / "all-effects.toml"))):
        device = SimulatedNI9234(RigPlant(spec), seed=3, hit_interval_s=(0.6, 0.8))
        device.configure(four)
        device.start()
        stream = np.empty((4, int(1.2 * rate_hz)))
        device.read(stream)
        out[f"{label}-stream"] = stream
        device = SimulatedNI9234(RigPlant(spec), seed=5, hit_interval_s=None)
        device.configure(default_hammer_and_accelerometer(rate_hz))
        device.start()
        records = device.sim_record_hits(4, int(0.5 * rate_hz))
        frf = compute_frf(records, rate_hz, WindowSettings(force_window_ms=20.0, exponential_end_fraction=0.05))
        out[f"{label}-h1"], out[f"{label}-h2"], out[f"{label}-coherence"] = frf.h1, frf.h2, frf.coherence
        band = (frf.freq_hz >= 20.0) & (frf.freq_hz <= 1000.0)
        for model in ("SD", "FOMGF"):
            fit = fit_model(model, frf.freq_hz[band], frf.h1[band], 25.05, decay_rate_1_s=frf.decay_rate_1_s)
            out[f"{label}-fit-{model}"] = np.array([*fit.params.values(), fit.rms])
        out[f"{label}-accelerance"] = rig_accelerance(spec, frf.freq_hz[band], frf.decay_rate_1_s)
        out[f"{label}-replay"] = simulate_response(spec, records[0, 0], rate_hz)
    return out


if __name__ == "__main__":
    np.savez_compressed(sys.argv[1], **figures())
