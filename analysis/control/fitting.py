"""Rational approximation of a frequency response: weighted relaxed vector fitting and Oustaloup's s^α.

* :func:`vector_fit` — Gustavsen & Semlyen's vector fitting (IEEE Trans. Power Delivery 14(3), 1999) with
  Gustavsen's relaxed non-triviality constraint (IEEE TPWRD 21(3), 2006): poles are relocated by solving a linear
  least-squares problem for a scaling function σ(s) and taking the zeros of σ; unstable poles are flipped into the
  left half-plane. Written here because the available implementation (scikit-rf's ``VectorFitting``) has no
  per-frequency weights, and a gas film's response spans decades: only a *relative* (weighted) fit gives a bounded
  relative error everywhere in the band.
* :func:`oustaloup` — Oustaloup's recursive pole/zero approximation of ``s^α`` over a band (Oustaloup et al.,
  IEEE TCAS-I 47(1), 2000), ``α`` in any range (the integer part is kept exact as ``s^n``).

Everything here is plain numpy on arrays of the Laplace variable in rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: vector-fitting iterations (pole relocations); a smooth response converges in a handful
VF_ITERATIONS = 12


@dataclass(frozen=True)
class PoleResidue:
    """``f(s) = d + Σ r_i / (s − p_i)`` with complex poles in conjugate pairs (rad/s); real coefficients overall."""

    poles: np.ndarray  # complex (n,)
    residues: np.ndarray  # complex (n,)
    constant: float

    def __call__(self, s: np.ndarray) -> np.ndarray:
        s = np.asarray(s, dtype=complex)
        return self.constant + (self.residues / (s[..., np.newaxis] - self.poles)).sum(axis=-1)

    @property
    def order(self) -> int:
        return int(self.poles.size)

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """A real state-space realisation (A, B, C, D): a real pole gives a 1×1 block, a complex pair a 2×2 block
        ``[[σ, ω], [−ω, σ]]`` with ``B = [2, 0]`` and ``C = [Re r, Im r]``."""
        n = self.order
        a, b, c = np.zeros((n, n)), np.zeros(n), np.zeros(n)
        i = 0
        for pole, residue in zip(self.poles, self.residues):
            if pole.imag < 0:
                continue
            if pole.imag == 0:
                a[i, i], b[i], c[i] = pole.real, 1.0, residue.real
                i += 1
            else:
                a[i:i + 2, i:i + 2] = [[pole.real, pole.imag], [-pole.imag, pole.real]]
                b[i:i + 2] = [2.0, 0.0]
                c[i:i + 2] = [residue.real, residue.imag]
                i += 2
        return a, b, c, float(self.constant)


def _pairs(poles: np.ndarray) -> np.ndarray:
    """Poles as real ones and conjugate pairs (upper member first), tiny imaginary parts made real."""
    poles = np.asarray(poles, dtype=complex)
    real = poles[np.abs(poles.imag) <= 1e-9 * np.abs(poles)].real
    upper = poles[poles.imag > 1e-9 * np.abs(poles)]
    ordered = [complex(p) for p in np.sort(real)]
    for pole in upper[np.argsort(np.abs(upper))]:
        ordered += [complex(pole), complex(pole.conjugate())]
    return np.array(ordered, dtype=complex)


def _basis(s: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """Real-coefficient basis of partial fractions, shape (len(s), n): 1/(s−p) for a real pole; for a pair
    1/(s−p) + 1/(s−p*) and j/(s−p) − j/(s−p*) (so residue ``r = x + jy`` has real coordinates x, y)."""
    columns = []
    i = 0
    while i < poles.size:
        pole = poles[i]
        if pole.imag == 0:
            columns.append(1.0 / (s - pole))
            i += 1
        else:
            first, second = 1.0 / (s - pole), 1.0 / (s - pole.conjugate())
            columns += [first + second, 1j * first - 1j * second]
            i += 2
    return np.stack(columns, axis=-1) if columns else np.zeros((s.size, 0), dtype=complex)


def _residues(poles: np.ndarray, coordinates: np.ndarray) -> np.ndarray:
    """Complex residues of every pole from the basis coordinates."""
    residues = np.empty(poles.size, dtype=complex)
    i = 0
    while i < poles.size:
        if poles[i].imag == 0:
            residues[i] = coordinates[i]
            i += 1
        else:
            residues[i] = coordinates[i] + 1j * coordinates[i + 1]
            residues[i + 1] = residues[i].conjugate()
            i += 2
    return residues


def _stacked(rows: np.ndarray) -> np.ndarray:
    """Complex least-squares rows as real ones (real parts over imaginary parts)."""
    return np.concatenate([rows.real, rows.imag])


def vector_fit(
    s: np.ndarray,
    response: np.ndarray,
    n_poles: int,
    weight: np.ndarray | None = None,
    constant: bool = True,
    start_band_rad_s: tuple[float, float] | None = None,
    iterations: int = VF_ITERATIONS,
) -> PoleResidue:
    """Fit ``d + Σ r_i/(s − p_i)`` with ``n_poles`` stable poles to ``response`` sampled at ``s = jω`` (rad/s).

    ``weight`` multiplies each sample's error (1/|response| gives a relative fit). The starting poles are real and
    log-spaced over ``start_band_rad_s`` (default: the sampled band): a fractional response is best approximated
    by interlaced real poles and zeros, and vector fitting moves them into complex pairs where that fits better.
    ``constant=False`` fits a strictly proper function.
    """
    s = np.asarray(s, dtype=complex)
    f = np.asarray(response, dtype=complex)
    w = np.ones(s.size) if weight is None else np.asarray(weight, dtype=float)
    if n_poles == 0:
        d = float(np.sum(w**2 * f.real) / np.sum(w**2)) if constant else 0.0
        return PoleResidue(np.zeros(0, complex), np.zeros(0, complex), d)
    low, high = start_band_rad_s or (float(np.min(np.abs(s))), float(np.max(np.abs(s))))
    poles = -np.geomspace(low, high, n_poles).astype(complex)
    n_const = 1 if constant else 0
    for _ in range(iterations):
        phi = _basis(s, poles)
        # unknowns: residues of σf (n), its constant, residues of σ (n), σ's constant d̃ (relaxed)
        left = np.hstack([phi, np.ones((s.size, n_const))])
        right = -f[:, np.newaxis] * np.hstack([phi, np.ones((s.size, 1))])
        rows = w[:, np.newaxis] * np.hstack([left, right])
        system = _stacked(rows)
        # relaxation: Re Σ_k σ(s_k) = N keeps σ away from the trivial zero solution (Gustavsen 2006)
        extra = np.concatenate([np.zeros(left.shape[1]), phi.sum(axis=0).real, [s.size]])
        scale = np.linalg.norm(w * f) / s.size
        system = np.vstack([system, scale * extra])
        rhs = np.zeros(system.shape[0])
        rhs[-1] = scale * s.size
        column_norms = np.linalg.norm(system, axis=0)
        column_norms[column_norms == 0] = 1.0
        solution = np.linalg.lstsq(system / column_norms, rhs, rcond=None)[0] / column_norms
        sigma = solution[left.shape[1]:]
        sigma_residues, sigma_constant = sigma[:-1], sigma[-1]
        if abs(sigma_constant) < 1e-8:
            sigma_constant = 1e-8 if sigma_constant >= 0 else -1e-8
        a, b, c, _ = PoleResidue(poles, _residues(poles, sigma_residues), 0.0).state_space()
        zeros = np.linalg.eigvals(a - np.outer(b, c) / sigma_constant)
        zeros = np.where(zeros.real > 0, -zeros.conjugate(), zeros)  # flip unstable poles
        poles = _pairs(zeros)
    phi = _basis(s, poles)
    design = np.hstack([phi, np.ones((s.size, n_const))])
    system = _stacked(w[:, np.newaxis] * design)
    column_norms = np.linalg.norm(system, axis=0)
    column_norms[column_norms == 0] = 1.0
    coordinates = np.linalg.lstsq(system / column_norms, _stacked(w * f), rcond=None)[0] / column_norms
    d = float(coordinates[-1]) if constant else 0.0
    return PoleResidue(poles, _residues(poles, coordinates[:poles.size]), d)


def oustaloup(alpha: float, band_rad_s: tuple[float, float], order: int) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Oustaloup's approximation of ``s^α`` over ``band_rad_s`` with ``2·order + 1`` real zeros and poles.

    Returns (zeros, poles, gain, integer power n): ``s^α ≈ s^n · gain · Π (s − z_k) / Π (s − p_k)`` with
    ``n = floor(α)`` and the fractional part ``ν = α − n`` approximated by
    ``ω_z,k = ω_b (ω_h/ω_b)^((k + N + (1 − ν)/2)/(2N + 1))``, ``ω_p,k = ω_b (ω_h/ω_b)^((k + N + (1 + ν)/2)/(2N + 1))``,
    ``k = −N … N``, gain ``ω_h^ν``.
    """
    power = int(np.floor(alpha))
    nu = alpha - power
    low, high = band_rad_s
    k = np.arange(-order, order + 1)
    ratio = high / low
    zeros = -low * ratio ** ((k + order + 0.5 * (1 - nu)) / (2 * order + 1))
    poles = -low * ratio ** ((k + order + 0.5 * (1 + nu)) / (2 * order + 1))
    return zeros, poles, float(high**nu), power


def oustaloup_response(alpha: float, band_rad_s: tuple[float, float], order: int, s: np.ndarray) -> np.ndarray:
    """The frequency response of :func:`oustaloup`'s approximation of ``s^α`` at ``s``."""
    zeros, poles, gain, power = oustaloup(alpha, band_rad_s, order)
    s = np.asarray(s, dtype=complex)
    return s**power * gain * np.prod((s[..., np.newaxis] - zeros) / (s[..., np.newaxis] - poles), axis=-1)
