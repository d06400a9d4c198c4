"""Hammer hits synthesised exactly in the frequency domain for diagnosis tests: sampled half-sine forces (1 ms ± 5 %,
150–250 N, 10 ms into 0.5 s records) times an accelerance on a four-times zero-padded grid, with sensor noise."""

from __future__ import annotations

from typing import Callable

import numpy as np

from gasfilm.analysis.diagnosis.recordings import Recordings


def synthesised_hits(
    accelerance_of: Callable[[np.ndarray], np.ndarray], rate_hz: float, hits: int, seed: int, source: str
) -> Recordings:
    """``hits`` records 3 s apart whose response is ``accelerance_of(freq_hz)`` ((m/s²)/N on the rfft grid of the
    padded record) applied to each sampled force."""
    rng = np.random.default_rng(seed)
    n_samples = int(0.5 * rate_hz)
    time_s = np.arange(n_samples) / rate_hz
    n_fft = 4 * n_samples
    accelerance = accelerance_of(np.fft.rfftfreq(n_fft, 1.0 / rate_hz))
    records = np.zeros((hits, 2, n_samples))
    for hit in range(hits):
        width_s = 1e-3 * (1 + 0.05 * rng.standard_normal())
        pulse = (time_s >= 0.01) & (time_s < 0.01 + width_s)
        force = np.where(pulse, rng.uniform(150, 250) * np.sin(np.pi * (time_s - 0.01) / width_s), 0.0)
        records[hit, 0] = force + rng.normal(0.0, 0.01, n_samples)
        response = np.fft.irfft(np.fft.rfft(force, n_fft) * accelerance, n_fft)[:n_samples]
        records[hit, 1] = response + rng.normal(0.0, 0.003, n_samples)
    return Recordings(records, rate_hz, np.arange(hits) * 3.0, None, None, None, source)
