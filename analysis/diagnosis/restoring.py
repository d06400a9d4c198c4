"""Model-free evidence for amplitude-dependent physics: the film's restoring force against displacement and velocity.

The mover obeys ``m·a = F − r(x, v)``: the force the film (and whatever else holds the mover) exerts is
``r = F − m·a``, measured sample by sample from each hit's recorded force and acceleration, with the displacement and
velocity integrated from the acceleration in the frequency domain. Everything is band-limited to the film's band
(around the resonance, inside the analysis band: integration drift and the hammer's high-frequency content removed)
— this is the restoring-force surface of Masri and Caughey (1979), read as Worden and Tomlinson (*Nonlinearity in
Structural Dynamics*, 2001) catalogue its shapes. A linear film gives a plane ``r = k·x + c·v``; each shape of the
catalogue adds one basis function to that plane and is judged by the χ² it removes, in units of the measured noise
of ``r`` (from the quiet pre-trigger) and per independent sample (the band-limited samples are correlated):

| shape | basis added to k·x + c·v | catalog term |
| --- | --- | --- |
| hardening / softening cubic stiffness | x³ (sign: hardening > 0) | ``cubic-stiffness`` |
| quadratic (flow) damping | v·\\|v\\| | ``quadratic-damping`` |
| Coulomb (dry) friction | sign(v), smoothed at 1 % of the peak velocity | ``friction`` |
| clearance / dead zone | clip(x, ±d) (stiffness missing or added near rest), d = 20 % of the peak | none |
| bilinear stiffness | max(x, 0) (different stiffness on either side) | none |
| asymmetric (quadratic) stiffness | x² | none |

A linear film whose stiffness depends on frequency (a fractional or memory film) does not leave a plane: its free
decay is not one exponential, the apparent stiffness changes along the decay as the amplitude falls, and x³ or a
dead zone follow that change. So each shape is judged against the *linear reference*: the plane plus the best linear
time-invariant description of ``r`` from ``x`` over all hits (the film's dynamic stiffness K(ω) = Σ R·X̄ / Σ |X|²,
pulse included, applied to each hit's displacement; Bendat & Piersol, *Random Data*, ch. 6). Whatever a linear film
does, at any frequency dependence, it does alike in every hit; an odd-symmetric shape (cubic, quadratic damping,
friction, clearance) is evidence only beyond that. The even shapes (bilinear, x²) make even harmonics no linear film
makes; but hits of similar levels are nearly scaled copies, whose even harmonics that reference would take in as a
frequency dependence (a bilinear film is exactly homogeneous), so they are judged against the plane alone.

Each basis function goes through the same band-pass as the measured force, so that the harmonics the nonlinearity
creates outside the band are removed from both sides alike. Only samples after the hammer pulse (free decay, where
``r = −m·a`` whatever the force sensor's calibration) whose displacement stands well above the noise are used.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gasfilm.analysis.quantities import band_text, rounded_band

#: χ² gain (noise units, independent samples) a shape needs over the linear reference to be evidence, and the share
#: of the reference's misfit beyond the noise it must remove.
SHAPE_SIGNIFICANCE = 25.0
SHAPE_SHARE = 0.3
#: The film's band, relative to the resonance (inside the analysis band).
FILM_BAND = (0.4, 2.5)
#: Samples are used while the hit's displacement envelope exceeds this fraction of its peak and 5× its noise.
ENVELOPE_FRACTION = 0.03
#: At most this many samples are drawn in a restoring-force figure (a scatter of every sample takes seconds).
MAX_DRAWN_SAMPLES = 8000
#: Shapes whose gain lies within this fraction of the best one's are not told apart from it.
TIE_FRACTION = 0.2


@dataclass
class Shape:
    """One shape of the restoring-force catalogue, fitted on top of the linear reference."""

    name: str
    term: str | None  # the catalog effect with this shape, or None
    chi2_gain: float  # over the linear reference, in noise units per independent sample
    share: float  # of the linear reference's misfit beyond the noise that this shape removes
    coefficient: float
    unit: str

    @property
    def significant(self) -> bool:
        return self.chi2_gain > SHAPE_SIGNIFICANCE and self.share >= SHAPE_SHARE

    def to_dict(self) -> dict:
        return {"shape": self.name, "term": self.term, "chi2_gain": round(self.chi2_gain, 1),
                "share": round(self.share, 3), "coefficient": self.coefficient, "unit": self.unit,
                "significant": self.significant}


@dataclass(frozen=True)
class RestoringSections:
    """The restoring force's two sections as drawn: per sample its hit, x (µm), v (mm/s), r − c·v and r − k·x (N)."""

    hit_index: np.ndarray
    displacement_um: np.ndarray
    velocity_mm_s: np.ndarray
    stiffness_part_n: np.ndarray
    damping_part_n: np.ndarray


@dataclass
class RestoringForce:
    """The film's restoring force from every hit, its linear plane and the catalogue shapes, best first."""

    band_hz: tuple[float, float]
    mass_kg: float
    displacement_m: np.ndarray  # samples used, all hits concatenated
    velocity_m_s: np.ndarray
    force_n: np.ndarray
    hit_index: np.ndarray  # which hit (0-based, of the hits used) each sample comes from
    stiffness_n_per_m: float
    damping_ns_per_m: float
    noise_n: float  # RMS noise of r in the band
    independent_samples: float
    shapes: list[Shape] = field(default_factory=list)

    @property
    def significant(self) -> list[Shape]:
        return [shape for shape in self.shapes if shape.significant]

    def sections(self) -> RestoringSections:
        """The stiffness section (r − c·v against x) and damping section (r − k·x against v) to draw, thinned to at
        most :data:`MAX_DRAWN_SAMPLES` samples."""
        step = max(1, self.force_n.size // MAX_DRAWN_SAMPLES)
        return RestoringSections(
            hit_index=self.hit_index[::step],
            displacement_um=self.displacement_m[::step] * 1e6,
            velocity_mm_s=self.velocity_m_s[::step] * 1e3,
            stiffness_part_n=self.force_n[::step] - self.damping_ns_per_m * self.velocity_m_s[::step],
            damping_part_n=self.force_n[::step] - self.stiffness_n_per_m * self.displacement_m[::step],
        )

    @property
    def best(self) -> Shape | None:
        """The shape that removes most, when it is significant; None: linear within the noise."""
        return self.shapes[0] if self.shapes and self.shapes[0].significant else None

    def close_to_best(self) -> list[Shape]:
        """Significant shapes that fit about as well as the best one (the data cannot tell them apart)."""
        best = self.best
        if best is None:
            return []
        return [shape for shape in self.significant if shape.chi2_gain >= (1 - TIE_FRACTION) * best.chi2_gain]

    def allows(self, term: str) -> bool:
        """Whether an amplitude-dependent catalog term is consistent with the measured shape (always, when the
        restoring force shows no significant shape: then it cannot choose)."""
        close = self.close_to_best()
        return not close or any(shape.term == term for shape in close)

    def description(self) -> str:
        """The shape in words, with its significance, and whether a catalog term has it."""
        band = band_text(*self.band_hz)
        best = self.best
        if best is None:
            top = self.shapes[0] if self.shapes else None
            detail = (f" (largest: {top.name}, χ² gain {top.chi2_gain:.0f}, {100 * top.share:.0f} % of the linear "
                      f"reference's misfit)" if top else "")
            return (f"the film's restoring force (F − m·a, {band}) is linear within the noise: no shape of the "
                    f"restoring-force catalogue stands out{detail}")
        close = self.close_to_best()
        names = " or ".join(shape.name for shape in close)
        terms = sorted({shape.term for shape in close if shape.term})
        text = (f"the film's restoring force (F − m·a, {band}) has the shape of {names} (χ² gain "
                f"{best.chi2_gain:.0f} over a linear film in noise units, significant above {SHAPE_SIGNIFICANCE:.0f}; "
                f"{100 * best.share:.0f} % of the linear reference's misfit)")
        if terms:
            return text + f"; the catalog term with that shape: {', '.join(terms)}"
        return text + "; no term of the catalog has that shape"

    def to_dict(self) -> dict:
        best = self.best
        return {"band_hz": rounded_band(*self.band_hz),
                "stiffness_n_per_m": self.stiffness_n_per_m, "damping_ns_per_m": self.damping_ns_per_m,
                "noise_n": self.noise_n, "independent_samples": round(self.independent_samples, 1),
                "shapes": [shape.to_dict() for shape in self.shapes],
                "best": best.name if best else None, "description": self.description()}


def _band_pass(freq_hz: np.ndarray, band_hz: tuple[float, float]) -> np.ndarray:
    """A smooth band-pass gain (raised-cosine edges a third of an octave wide)."""
    low, high = band_hz
    gain = np.ones_like(freq_hz)
    for edge, rising in ((low, True), (high, False)):
        lower, upper = (edge / 1.26, edge) if rising else (edge, edge * 1.26)
        ramp = np.clip((freq_hz - lower) / (upper - lower), 0.0, 1.0)
        taper = 0.5 - 0.5 * np.cos(np.pi * ramp)
        gain *= taper if rising else 1.0 - taper
    return gain


def restoring_force(
    records: np.ndarray,
    sample_rate_hz: float,
    mass_kg: float,
    resonance_hz: float,
    analysis_band_hz: tuple[float, float],
) -> RestoringForce | None:
    """The restoring force of every hit's free decay and the catalogue shapes fitted to it; None when the records
    give no usable free decay (no quiet pre-trigger, or nothing above the noise)."""
    records = np.asarray(records, float)
    hit_count, _, n_samples = records.shape
    band = (max(FILM_BAND[0] * resonance_hz, analysis_band_hz[0]), min(FILM_BAND[1] * resonance_hz,
                                                                     analysis_band_hz[1]))
    if band[1] <= 1.2 * band[0]:
        return None
    n_fft = 2 * n_samples
    freq_hz = np.fft.rfftfreq(n_fft, 1.0 / sample_rate_hz)
    gain = _band_pass(freq_hz, band)
    omega = 2 * np.pi * freq_hz
    omega[0] = 1.0

    def filtered(spectrum: np.ndarray, factor: np.ndarray | float = 1.0) -> np.ndarray:
        return np.fft.irfft(spectrum * gain * factor, n_fft, axis=-1)[..., :n_samples]

    force = records[:, 0] - np.median(records[:, 0, : max(n_samples // 100, 4)], axis=1, keepdims=True)
    acceleration = records[:, 1]
    acceleration_spectrum = np.fft.rfft(acceleration, n_fft, axis=-1)  # (transformed once for its three uses)
    force_b = filtered(np.fft.rfft(force, n_fft, axis=-1))
    acceleration_b = filtered(acceleration_spectrum)
    velocity = filtered(acceleration_spectrum, 1.0 / (1j * omega))
    displacement = filtered(acceleration_spectrum, -1.0 / omega**2)
    restoring = force_b - mass_kg * acceleration_b

    peaks = np.argmax(np.abs(force), axis=1)
    level = np.abs(force[np.arange(hit_count), peaks])
    starts, ends, quiet = [], [], []
    for hit in range(hit_count):
        above = np.flatnonzero(np.abs(force[hit]) > 0.02 * level[hit])
        start, end = int(above[0]), int(above[-1])
        # the pulse ends where the force first falls below 2 % after its peak
        after = np.flatnonzero(np.abs(force[hit, peaks[hit]:]) <= 0.02 * level[hit])
        end = int(peaks[hit] + after[0]) if after.size else end
        starts.append(start)
        ends.append(end)
        quiet.append(max(start - int(0.002 * sample_rate_hz), 0))
    quiet_samples = min(quiet)
    if quiet_samples < 16:
        return None
    # the noise of r and x in the band, from the raw quiet pre-trigger (the band-pass spreads the pulse into it)
    quiet_force = force[:, :quiet_samples] - force[:, :quiet_samples].mean(axis=1, keepdims=True)
    quiet_acceleration = acceleration[:, :quiet_samples] - acceleration[:, :quiet_samples].mean(axis=1, keepdims=True)
    hann = np.hanning(quiet_samples)
    coarse_hz = np.fft.rfftfreq(quiet_samples, 1.0 / sample_rate_hz)

    def density(quiet: np.ndarray) -> np.ndarray:
        """Noise power per frequency bin of the padded transform (periodogram of the quiet samples, averaged)."""
        periodogram = np.mean(np.abs(np.fft.rfft(quiet * hann, axis=1)) ** 2, axis=0) / np.sum(hann**2)
        return np.interp(freq_hz, coarse_hz, periodogram)

    band_power = gain**2 / n_fft * 2.0  # a white noise of unit variance per sample, through the band-pass
    noise_n = float(np.sqrt(np.sum((density(quiet_force) + mass_kg**2 * density(quiet_acceleration)) * band_power)))
    noise_x = float(np.sqrt(np.sum(density(quiet_acceleration) / omega**4 * band_power)))

    spectrum = np.fft.rfft(displacement, n_fft, axis=-1)
    spectrum[:, 1:] *= 2.0
    envelope = np.abs(np.fft.ifft(np.concatenate((spectrum, np.zeros((hit_count, n_fft - spectrum.shape[1]))),
                                                 axis=1), axis=1)[:, :n_samples])
    selected = []
    for hit in range(hit_count):
        begin = ends[hit] + int(0.5e-3 * sample_rate_hz)
        threshold = max(ENVELOPE_FRACTION * float(envelope[hit, begin:].max(initial=0.0)), 5.0 * noise_x)
        keep = np.flatnonzero(envelope[hit, begin:] > threshold) + begin
        breaks = np.flatnonzero(np.diff(keep) > 1)
        if breaks.size:
            keep = keep[: breaks[0] + 1]  # the first stretch above the threshold: the decay itself
        selected.append(keep)
    if sum(s.size for s in selected) < 50:
        return None

    rows = np.concatenate([np.full(s.size, hit) for hit, s in enumerate(selected)])
    x = np.concatenate([displacement[hit, s] for hit, s in enumerate(selected)])
    v = np.concatenate([velocity[hit, s] for hit, s in enumerate(selected)])
    r = np.concatenate([restoring[hit, s] for hit, s in enumerate(selected)])
    x_peak, v_peak = float(np.max(np.abs(x))), float(np.max(np.abs(v)))
    independent = r.size * 2.0 * (band[1] - band[0]) / sample_rate_hz

    def basis(function) -> np.ndarray:
        """A basis function of the full displacement and velocity records, band-passed like r, at the samples."""
        values = filtered(np.fft.rfft(function(displacement, velocity), n_fft, axis=-1))
        return np.concatenate([values[hit, s] for hit, s in enumerate(selected)])

    linear = np.column_stack((x, v))
    coefficients = _least_squares(linear, r)
    # the best linear time-invariant description of r from x over all hits, applied to each hit's displacement
    spectrum_r = np.fft.rfft(restoring, n_fft, axis=-1)
    spectrum_x = np.fft.rfft(displacement, n_fft, axis=-1)
    film = np.sum(spectrum_r * np.conj(spectrum_x), axis=0) / np.maximum(np.sum(np.abs(spectrum_x) ** 2, axis=0),
                                                                         1e-300)
    lti = np.fft.irfft(film * spectrum_x, n_fft, axis=-1)[:, :n_samples]
    references = {True: linear, False: np.column_stack((x, v, np.concatenate([lti[hit, s]
                                                                              for hit, s in enumerate(selected)])))}
    rss_references = {key: float(np.sum((r - design @ _least_squares(design, r)) ** 2))
                      for key, design in references.items()}
    catalogue = (  # name, catalog term, basis, unit, even (judged against the plane)
        ("cubic stiffness", "cubic-stiffness", lambda d, u: d**3, "N/m³", False),
        ("quadratic damping", "quadratic-damping", lambda d, u: u * np.abs(u), "N·s²/m²", False),
        ("Coulomb friction", "friction", lambda d, u: np.tanh(u / (0.01 * v_peak)), "N", False),
        ("clearance / dead zone", None, lambda d, u: np.clip(d, -0.2 * x_peak, 0.2 * x_peak), "N/m", False),
        ("bilinear stiffness", None, lambda d, u: np.maximum(d, 0.0), "N/m", True),
        ("asymmetric (quadratic) stiffness", None, lambda d, u: d**2, "N/m²", True),
    )
    shapes = []
    for name, term, function, unit, even in catalogue:
        shape_basis = basis(function)
        reference, rss_reference = references[even], rss_references[even]
        design = np.column_stack((reference, shape_basis))
        rss = float(np.sum((r - design @ _least_squares(design, r)) ** 2))
        fitted = _least_squares(np.column_stack((x, v, shape_basis)), r)  # the shape's own coefficient, as drawn
        variance = max(noise_n**2, rss / max(r.size - design.shape[1], 1))
        gain = (rss_reference - rss) / variance * independent / r.size
        excess = rss_reference - r.size * noise_n**2  # the reference's misfit beyond the noise (none: nothing to share)
        share = (rss_reference - rss) / excess if excess > 0 else 0.0
        shapes.append(Shape(_named(name, fitted[2]), term if _term_sign_ok(term, fitted[2]) else None, gain,
                            float(np.clip(share, 0.0, 1.0)), float(fitted[2]), unit))
    shapes.sort(key=lambda shape: shape.chi2_gain, reverse=True)
    return RestoringForce(band, mass_kg, x, v, r, rows, float(coefficients[0]), float(coefficients[1]), noise_n,
                          independent, shapes)


def _least_squares(design: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least squares with the columns equilibrated (x³ and v are twenty orders of magnitude apart)."""
    norms = np.linalg.norm(design, axis=0)
    norms[norms == 0] = 1.0
    solution, *_ = np.linalg.lstsq(design / norms, target, rcond=None)
    return solution / norms


def _named(name: str, coefficient: float) -> str:
    if name == "cubic stiffness":
        return f"{'hardening' if coefficient > 0 else 'softening'} cubic stiffness"
    if name == "clearance / dead zone":
        return "clearance / dead zone (softer near rest)" if coefficient < 0 else "pre-load (stiffer near rest)"
    return name


def _term_sign_ok(term: str | None, coefficient: float) -> bool:
    """A catalog term describes a shape only with the sign it can take (friction and quadratic damping dissipate)."""
    return term is not None and (term == "cubic-stiffness" or coefficient > 0)


__all__ = ["RestoringForce", "Shape", "restoring_force"]
