"""What the film models cannot mean for an FRF, said the same way by ``gasfilm fit`` and the session report: a
structure that is not a mass on a film (its accelerance over the top of the band far from the mass line 1/m), and
resonances in the band beyond the strongest one (a structure with more modes than one resonance on a mass)."""

from __future__ import annotations

from typing import Any

import numpy as np

#: The top fraction of the band (in lines) where |H1| is compared with the mass line 1/m.
MASS_LINE_TOP_FRACTION = 0.2
#: |H1|·m outside [1/factor, factor] over the top of the band: not a mass on a film.
MASS_LINE_FACTOR = 2.0


def mass_line_warning(freq_hz: Any, h1: Any, mass_kg: float) -> str | None:
    """One line when |H1| over the top of the band is far from the mass line 1/m (None when it is close)."""
    top = np.abs(h1[-max(1, int(MASS_LINE_TOP_FRACTION * len(h1))):])
    level = float(np.median(top))
    ratio = level * mass_kg
    if 1 / MASS_LINE_FACTOR <= ratio <= MASS_LINE_FACTOR:
        return None
    return (f"|H1| at the top of the band ({freq_hz[-len(top)]:.0f}–{freq_hz[-1]:.0f} Hz) is {level:.3g} (m/s²)/N, "
            f"{ratio:.2g} × the mass line 1/m = {1 / mass_kg:.3g} for m = {mass_kg:g} kg: this is not a mass on a "
            f"gas film (or the mass is wrong); the fitted parameters mean little")


def other_resonances_hz(frf: Any, band_hz: tuple[float, float]) -> list[float]:
    """Resonances of |H1| inside ``band_hz`` beyond the strongest one (which the film models describe), in Hz."""
    from gasfilm.analysis.spectra import resonance_lines

    inside = [int(line) for line in resonance_lines(frf) if band_hz[0] <= frf.freq_hz[line] <= band_hz[1]]
    return sorted(float(frf.freq_hz[line]) for line in inside[1:])


def not_explained_warning(resonances_hz: list[float]) -> str | None:
    """One line naming the resonances no film model explains (None when there are none)."""
    if not resonances_hz:
        return None
    return (f"NOT explained by any film model (one resonance on a mass): resonances at "
            f"{', '.join(f'{f:.0f}' for f in resonances_hz)} Hz in the band — a structure with more modes; the fits "
            f"describe the strongest resonance only")


def fit_warnings(frf: Any, band: np.ndarray, masses_kg: list[float]) -> list[str]:
    """Every warning ``gasfilm fit`` gives for fits of ``frf`` on its lines ``band`` (a mask) with the mover masses
    ``masses_kg``."""
    if not np.any(band):
        return []
    freq_hz = frf.freq_hz[band]
    warnings = [mass_line_warning(freq_hz, frf.h1[band], mass) for mass in dict.fromkeys(masses_kg)]
    warnings.append(not_explained_warning(other_resonances_hz(frf, (float(freq_hz[0]), float(freq_hz[-1])))))
    return [warning for warning in warnings if warning]
