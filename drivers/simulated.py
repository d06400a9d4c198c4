"""A simulated NI 9234 with the rig behind it: hammer, mover on a gas film, sensors and the module's signal chain.

Each impact is synthesised exactly in the frequency domain. The hammer pulse (a half-sine whose width is set by the
tip) has a closed-form spectrum; the mover's acceleration spectrum for it comes from the rig the caller hands in
(a :class:`~gasfilm.drivers.plant.Plant`, asked on a ×2 grid so that a nonlinear plant can solve the equation of
motion). Both channels then pass through the SAME anti-aliasing filter of the module — linear phase, flat to 0.45·fs, raised-cosine transition to
zero at 0.55·fs, input delay 38.4/fs + 3 µs — evaluated on a grid twice as fine as the sample rate and decimated
(spectral folding), so 0.50–0.55·fs aliases into 0.45–0.50·fs as on the real module while the alias-free band is
exact. Sampling the continuous pulse directly would alias its high-frequency content, which the mass line turns
into a several-percent FRF error at low frequency; that does not happen here.

A plant with several responses (:class:`~gasfilm.drivers.plant.MultiResponsePlant`: a rigid mover seen by
accelerometers at different points) gives one acceleration spectrum per accelerometer, each through the same chain.
Each hit's decimated record (long enough to decay) is overlap-added into the stream, so signals are continuous
across chunks and hits may overlap. Per channel, the stream then gets, in order: mains interference, the conversion
to volts with the sensor's true sensitivity (the plant's), the AC-coupling high-pass (first order, 0.5 Hz, the same on
every channel, state carried across chunks), white sensor and module noise, ±5 V clipping with the overload flag,
24-bit quantisation, and the conversion back to N or m/s² with the *configured* sensitivity (as the real module
does). Same seed → same samples, whatever the chunk sizes: hits come from their own random stream and every channel's
noise from its own.
"""

from __future__ import annotations

import threading
import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.fft
import scipy.signal

from gasfilm.drivers.errors import (
    ADCOverloadWarning,
    BufferOverflowError,
    DeviceError,
    DeviceRemovedError,
    OpenSensorError,
    ReadTimeoutError,
    SettingError,
)
from gasfilm.drivers.interface import (
    NI9234_ADC_BITS,
    NI9234_ALIAS_FREE_FRACTION,
    NI9234_INPUT_RANGE_V,
    ChannelKind,
    ChannelStatus,
    DaqConfig,
    check_read_buffer,
    default_hammer_and_accelerometer,
    validate_config,
)
from gasfilm.drivers.plant import TIPS_PULSE_WIDTH_S, MultiResponsePlant, Plant

#: The module's signal chain (NI 9234 data sheet figures).
AA_PASSBAND_FRACTION = NI9234_ALIAS_FREE_FRACTION
AA_STOPBAND_FRACTION = 0.55
INPUT_DELAY_SAMPLES = 38.4
INPUT_DELAY_EXTRA_S = 3e-6
AC_COUPLING_HZ = 0.5
MODULE_NOISE_V_PER_SQRT_HZ = 3.1e-7  # about 50 µV rms idle-channel noise at 51.2 kS/s
LSB_V = 2 * NI9234_INPUT_RANGE_V / 2**NI9234_ADC_BITS
CODE_MIN_V = -(2 ** (NI9234_ADC_BITS - 1)) * LSB_V
CODE_MAX_V = (2 ** (NI9234_ADC_BITS - 1) - 1) * LSB_V

PACINGS = ("fast", "realtime")
FAULT_KINDS = ("overflow", "device_removed", "open_sensor", "overload")
OVERLOAD_HIT_FULL_SCALE = 1.5  # an overload hit drives the force channel to 1.5 × full scale
PRE_HIT_SAMPLES = 64  # each hit's record starts this early, so the AA filter's pre-ringing is kept
DOUBLE_HIT_GAP_S = (1.0e-3, 4.0e-3)
DOUBLE_HIT_FRACTION = (0.2, 0.5)


def half_sine_spectrum(freq_hz: np.ndarray, width_s: float) -> np.ndarray:
    """Fourier transform (N·s per N of peak) of a half-sine pulse ``sin(πt/T)`` on ``0 ≤ t ≤ T``, for ``f ≥ 0``.

    ``P(ω) = 2πT·e^{-jωT/2}·cos(ωT/2)/(π² − ω²T²)``, written with ``sinc`` so it stays finite at ``ω = π/T``.
    """
    u = np.pi * np.asarray(freq_hz, dtype=float) * width_s  # ωT/2
    return np.pi * width_s * np.exp(-1j * u) * np.sinc(0.5 - u / np.pi) / (np.pi + 2 * u)


def anti_alias_response(freq_hz: np.ndarray, sample_rate_hz: float) -> np.ndarray:
    """The module's anti-aliasing filter incl. its input delay: flat to 0.45·fs, raised cosine to 0 at 0.55·fs."""
    freq_hz = np.asarray(freq_hz, dtype=float)
    low, high = AA_PASSBAND_FRACTION * sample_rate_hz, AA_STOPBAND_FRACTION * sample_rate_hz
    ramp = np.clip((freq_hz - low) / (high - low), 0.0, 1.0)
    magnitude = 0.5 * (1.0 + np.cos(np.pi * ramp))
    delay_s = INPUT_DELAY_SAMPLES / sample_rate_hz + INPUT_DELAY_EXTRA_S
    return magnitude * np.exp(-2j * np.pi * freq_hz * delay_s)


@dataclass(frozen=True)
class SimulatedHit:
    """A true impact: when the hammer touched (s since start), its peak force, tip, and whether it bounced.

    The samples show the impact :attr:`SimulatedNI9234.sim_input_delay_s` later (the module's filter delay).
    """

    time_s: float
    peak_force_n: float
    tip: str
    double: bool
    overload: bool = False
    on_demand: bool = False


@dataclass(frozen=True)
class _Pulse:
    delay_s: float
    peak_force_n: float
    width_s: float


class SimulatedNI9234:
    """The simulated NI 9234 (device name ``"sim"``) with a rig behind it.

    ``plant``: the rig behind it (a :class:`~gasfilm.drivers.plant.Plant`; for a rig spec, the caller builds a
    :class:`gasfilm.analysis.physics.plant.RigPlant`). ``pacing="realtime"`` makes ``read`` wait for the samples as
    the real module would (``speed`` times faster: 2.0 streams two seconds of signal a second); ``"fast"`` delivers at
    once. ``hit_interval_s=(lo, hi)`` hits at uniformly random
    intervals (the first after half of one), ``None`` only on demand (:meth:`sim_hit`). ``tip``, ``force_n``,
    ``force_spread`` (uniform ± fraction) and ``double_hit_rate`` default to the plant's hammer. ``noise=False``
    turns sensor and module noise off, ``quantize=False`` the 24-bit quantisation. ``buffer_s`` is how much unread
    data the device holds before it overflows (realtime pacing; at ``speed`` N, N times more: a reader gets the time to
    catch up that it gets at real time). Until :meth:`configure`, the setup is the paper's
    hammer + accelerometer.
    """

    name = "sim"

    def __init__(
        self,
        plant: Plant,
        seed: int = 0,
        pacing: str = "fast",
        hit_interval_s: tuple[float, float] | None = (1.5, 3.0),
        tip: str | None = None,
        force_n: float | None = None,
        force_spread: float | None = None,
        double_hit_rate: float | None = None,
        noise: bool = True,
        quantize: bool = True,
        buffer_s: float = 5.0,
        speed: float = 1.0,
    ) -> None:
        if not isinstance(plant, Plant):
            raise SettingError(f"sim plant: {plant!r} is not a Plant (gasfilm.drivers.plant)")
        self.plant = plant
        hammer = plant.hammer
        self.tip = hammer.tip if tip is None else tip
        self.force_n = hammer.force_n if force_n is None else float(force_n)
        self.force_spread = hammer.force_spread if force_spread is None else float(force_spread)
        self.double_hit_rate = hammer.double_hit_rate if double_hit_rate is None else float(double_hit_rate)
        self._check_tip(self.tip)
        if pacing not in PACINGS:
            raise SettingError(f"sim pacing: '{pacing}' is not valid; allowed: {', '.join(PACINGS)}")
        if hit_interval_s is not None and not (0 < hit_interval_s[0] <= hit_interval_s[1]):
            raise SettingError(f"sim hit_interval_s: {hit_interval_s} must be (lo, hi) with 0 < lo ≤ hi, or None")
        if not self.force_n > 0:
            raise SettingError(f"sim force_n: {self.force_n} N must be > 0")
        if not 0 <= self.force_spread < 1:
            raise SettingError(f"sim force_spread: {self.force_spread} must be in [0, 1)")
        if not 0 <= self.double_hit_rate <= 1:
            raise SettingError(f"sim double_hit_rate: {self.double_hit_rate} must be in [0, 1]")
        if not buffer_s > 0:
            raise SettingError(f"sim buffer_s: {buffer_s} s must be > 0")
        if not (isinstance(speed, (int, float)) and 0 < speed < float("inf")):
            raise SettingError(f"sim speed: {speed} must be a number > 0 (times real time)")
        self.seed = seed
        self.pacing = pacing
        self.hit_interval_s = hit_interval_s
        self.noise = noise
        self.quantize = quantize
        self.buffer_s = buffer_s
        self.speed = float(speed)
        self._config: DaqConfig = default_hammer_and_accelerometer()
        self._running = False
        self._closed = False
        self._fault: DeviceError | None = None
        self._device_removed = False
        self._open_sensor = np.zeros(len(self._config.channels), bool)
        self._overload_next_hit = False
        self._status = ChannelStatus.clear(len(self._config.channels))
        self._hits: list[SimulatedHit] = []
        self._lock = threading.RLock()  # the GUI's virtual hammer runs in another thread than the reader

    # --- DaqDevice -----------------------------------------------------------------------------------------------

    def configure(self, config: DaqConfig) -> None:
        """Validate and keep the setup (NI 9234 rules); the device must not be running."""
        if self._running:
            raise SettingError("sim: stop the device before configuring it")
        self._config = validate_config(config)
        self.plant.response_duration_s(config.sample_rate_hz)  # (a plant that cannot be simulated says so now)
        channel_count = len(config.channels)
        self._open_sensor = np.zeros(channel_count, bool)
        self._status = ChannelStatus.clear(channel_count)

    @property
    def config(self) -> DaqConfig:
        """The setup; until :meth:`configure` is called, the paper's hammer + accelerometer at 12.8 kS/s."""
        return self._config

    @property
    def sample_rate_hz(self) -> float:
        return self.config.sample_rate_hz

    @property
    def sim_input_delay_s(self) -> float:
        """Delay from an impact to its appearance in the samples (the module's filter group delay)."""
        return INPUT_DELAY_SAMPLES / self.sample_rate_hz + INPUT_DELAY_EXTRA_S

    def start(self) -> None:
        """Start a fresh acquisition at sample 0 (hits, noise and filters restart from the seed)."""
        if self._closed:
            raise SettingError("sim: the device is closed")
        if self._device_removed:
            raise DeviceRemovedError("sim: the device was removed (DAQmx -201003)")
        config = self.config
        fs = config.sample_rate_hz
        channel_count = len(config.channels)
        kinds = [ChannelKind(channel.kind) for channel in config.channels]
        self._force_row = kinds.index(ChannelKind.FORCE) if ChannelKind.FORCE in kinds else None
        # which synthesised signal each channel carries: 0 hammer, 1… the responses (the k-th acceleration channel
        # the plant's response k; every one the only response of a one-response plant), then nothing (noise only)
        responses = self.plant.response_count if isinstance(self.plant, MultiResponsePlant) else 1
        response_of_channel = {row: (k if responses > 1 else 0) for k, row in
                               enumerate(row for row, kind in enumerate(kinds) if kind is ChannelKind.ACCELERATION)}
        if response_of_channel and max(response_of_channel.values()) >= responses:
            raise SettingError(f"sim: {len(response_of_channel)} acceleration channels configured; the rig has "
                               f"{responses} accelerometers")
        self._responses = responses
        self._signal_of_channel = np.array([
            0 if row == self._force_row else (1 + response_of_channel[row] if row in response_of_channel
                                              else 1 + responses)
            for row, kind in enumerate(kinds)
        ])
        self._channel_kinds = [kind.value for kind in kinds]
        self._rows_of_channel_kind = {
            name: np.array([row for row, kind in enumerate(kinds) if kind.value == name]) for name in {k.value for k in kinds}
        }
        own_sensor = responses > 1  # each accelerometer its own sensitivity and noise
        self._true_v_per_si = np.array([
            self.plant.response_sensitivity_v_per_si(response_of_channel[row]) if own_sensor and row in
            response_of_channel else self.plant.sensitivity_v_per_si(kind.value) for row, kind in enumerate(kinds)])
        self._configured_v_per_si = np.array([channel.sensitivity_v_per_si for channel in config.channels])
        nyquist_bandwidth = np.sqrt(fs / 2)
        sensor_noise_v = np.array([
            (self.plant.response_noise_per_sqrt_hz(response_of_channel[row]) if own_sensor and row in
             response_of_channel else self.plant.noise_per_sqrt_hz(kind.value)) * sensitivity
            for row, (kind, sensitivity) in enumerate(zip(kinds, self._true_v_per_si))
        ])
        module_noise_v = MODULE_NOISE_V_PER_SQRT_HZ
        self._noise_rms_v = nyquist_bandwidth * np.hypot(sensor_noise_v, module_noise_v) if self.noise else None
        self._hp_b, self._hp_a = scipy.signal.butter(1, AC_COUPLING_HZ, "highpass", fs=fs)
        self._hp_state = np.zeros((channel_count, 1))
        self._filter_groups: tuple[bytes, np.ndarray, np.ndarray, dict[str, np.ndarray]] | None = None
        sequence = np.random.SeedSequence(self.seed)
        schedule_seq, demand_seq, *noise_seqs = sequence.spawn(2 + channel_count)
        self._schedule_rng = np.random.default_rng(schedule_seq)
        self._demand_rng = np.random.default_rng(demand_seq)
        self._noise_rngs = [np.random.default_rng(seq) for seq in noise_seqs]
        tail_s = self.plant.response_duration_s(fs)
        self._segment_samples = scipy.fft.next_fast_len(PRE_HIT_SAMPLES + int(np.ceil(tail_s * fs)), real=True)
        self._prepare_synthesis()
        self._contributions: list[tuple[int, np.ndarray]] = []
        self._hits = []
        self._next_auto_time_s = (
            0.5 * self._schedule_rng.uniform(*self.hit_interval_s) if self.hit_interval_s else None
        )
        self._position = 0
        self._fault = self._open_sensor_error() if self._open_sensor.any() else None
        self._status = ChannelStatus(np.zeros(channel_count, bool), self._open_sensor.copy())
        self._started_wall_s = time.monotonic()
        self._running = True

    def read(self, out: np.ndarray, timeout_s: float = 10.0) -> int:
        """Fill ``out`` (channels × samples) in N and m/s²; blocks in realtime pacing. Returns samples per channel."""
        if not self._running:
            raise SettingError("sim: the device is not running; call start() first")
        check_read_buffer(out, len(self.config.channels))
        if self._fault is not None:
            raise self._fault
        n_samples = out.shape[1]
        if self.pacing == "realtime":
            self._wait_for(n_samples, timeout_s)
        with self._lock:
            if self._fault is not None:
                raise self._fault
            overload = self._generate(out)
            self._status = ChannelStatus(overload, self._open_sensor.copy())
        if overload.any():
            labels = ", ".join(self.config.channels[row].label for row in np.flatnonzero(overload))
            warnings.warn(ADCOverloadWarning(f"sim: ADC overload (±5 V clipped) on {labels}"), stacklevel=2)
        return n_samples

    def status(self) -> ChannelStatus:
        """Overload flags of the last read; open-sensor flags as they are now."""
        return ChannelStatus(self._status.overload.copy(), self._open_sensor.copy())

    def stop(self) -> None:
        self._running = False

    def close(self) -> None:
        self._running = False
        self._closed = True

    def __enter__(self) -> "SimulatedNI9234":
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # --- simulator-only hooks ------------------------------------------------------------------------------------

    @property
    def sim_hits(self) -> tuple[SimulatedHit, ...]:
        """The true impacts synthesised so far, in time order of synthesis."""
        return tuple(self._hits)

    def sim_hit(self, tip: str | None = None, force_n: float | None = None) -> SimulatedHit:
        """The virtual hammer: an impact starting at the next unread sample (random amplitude unless ``force_n``)."""
        if not self._running:
            raise SettingError("sim: the device is not running; call start() first")
        tip = self.tip if tip is None else tip
        self._check_tip(tip)
        with self._lock:
            hit_time_s = self._position / self.sample_rate_hz
            pulses, double = self._draw_pulses(self._demand_rng, tip, force_n)
            return self._synthesise_hit(hit_time_s, tip, pulses, double, on_demand=True)

    def sim_record_hits(self, hits: int, record_samples: int, tip: str | None = None) -> np.ndarray:
        """Records of ``hits`` virtual-hammer impacts, each starting at its record's first sample: (hits, channels,
        record_samples) in N and m/s². One record's worth of signal is read and dropped first so that the AC coupling
        and noise are settled; the device must be running."""
        buffer = np.empty((len(self.config.channels), record_samples))
        self.read(buffer)
        records = np.empty((hits, *buffer.shape))
        for index in range(hits):
            self.sim_hit(tip=tip)
            self.read(records[index])
        return records

    def sim_inject_fault(self, kind: str, channel: int | None = None) -> None:
        """Make the next read fail like the real module: ``overflow``, ``device_removed``, ``open_sensor``
        (``channel`` index, default the first acceleration channel) or ``overload`` (the next hit clips)."""
        if kind not in FAULT_KINDS:
            raise SettingError(f"sim fault: '{kind}' is not known; allowed: {', '.join(FAULT_KINDS)}")
        with self._lock:
            if kind == "overflow":
                self._fault = BufferOverflowError(
                    "sim: the device buffer overflowed; the reader fell behind (DAQmx -200361)"
                )
            elif kind == "device_removed":
                self._device_removed = True
                self._fault = DeviceRemovedError("sim: the device was removed mid-stream (DAQmx -201003)")
            elif kind == "open_sensor":
                config = self.config
                if channel is None:
                    kinds = [ChannelKind(c.kind) for c in config.channels]
                    channel = kinds.index(ChannelKind.ACCELERATION) if ChannelKind.ACCELERATION in kinds else 0
                if not 0 <= channel < len(config.channels):
                    raise SettingError(f"sim fault channel: {channel} is not a configured channel index")
                self._open_sensor[channel] = True
                self._fault = self._open_sensor_error()
            else:
                self._overload_next_hit = True

    def _open_sensor_error(self) -> OpenSensorError:
        labels = ", ".join(self.config.channels[row].label for row in np.flatnonzero(self._open_sensor))
        return OpenSensorError(f"sim: open IEPE sensor on {labels}; check the sensor and its cable")

    def sim_clear_faults(self) -> None:
        """Reconnect everything: clears open sensors, a removed device and a pending fault (restart to read on)."""
        self._fault = None
        self._device_removed = False
        self._open_sensor[:] = False

    # --- synthesis -----------------------------------------------------------------------------------------------

    @staticmethod
    def _check_tip(tip: str) -> None:
        if tip not in TIPS_PULSE_WIDTH_S:
            raise SettingError(f"sim tip: '{tip}' is not known; allowed: {', '.join(TIPS_PULSE_WIDTH_S)}")

    def _draw_pulses(
        self, rng: np.random.Generator, tip: str, force_n: float | None
    ) -> tuple[list[_Pulse], bool]:
        """One impact's pulses; always draws the same count of random numbers so the sequence stays aligned."""
        amplitude_jitter, double_draw, gap_draw, fraction_draw = rng.uniform(size=4)
        peak_n = self.force_n * (1 + self.force_spread * (2 * amplitude_jitter - 1)) if force_n is None else force_n
        if self._overload_next_hit:
            peak_n = OVERLOAD_HIT_FULL_SCALE * NI9234_INPUT_RANGE_V / self.plant.sensitivity_v_per_si("force")
        width_s = TIPS_PULSE_WIDTH_S[tip]
        pulses = [_Pulse(0.0, peak_n, width_s)]
        double = bool(double_draw < self.double_hit_rate)
        if double:
            gap_s = DOUBLE_HIT_GAP_S[0] + gap_draw * (DOUBLE_HIT_GAP_S[1] - DOUBLE_HIT_GAP_S[0])
            fraction = DOUBLE_HIT_FRACTION[0] + fraction_draw * (DOUBLE_HIT_FRACTION[1] - DOUBLE_HIT_FRACTION[0])
            pulses.append(_Pulse(width_s + gap_s, fraction * peak_n, width_s))
        return pulses, double

    def _prepare_synthesis(self) -> None:
        """What every hit's synthesis shares, computed once per start: the ×2 grid (2·n_out samples at 2·fs, bin
        spacing fs/n_out), the bins the module keeps (up to its AA stopband; a nonlinear plant solves the motion over
        the whole grid), each channel's chain (AA filter × the plant's channel transfer × fs, from the continuous
        spectrum in N·s to the DFT of the sampled signal) and the decimation's folding indices."""
        fs, n_out = self.sample_rate_hz, self._segment_samples
        band = int(np.floor(AA_STOPBAND_FRACTION * n_out)) + 1
        self._freq_hz = np.arange(band if self.plant.is_linear else n_out + 1) * fs / n_out
        self._s = 2j * np.pi * self._freq_hz
        self._s[0] = 2j * np.pi * 1e-9 * fs / n_out
        aa = anti_alias_response(self._freq_hz[:band], fs)
        self._chain = np.stack([aa * self.plant.channel_transfer(channel, self._s[:band]) * fs
                                for channel in ("force", "acceleration")])
        n_half = n_out // 2 + 1
        mirror = n_out - np.arange(n_half)
        self._fold_kept = min(n_half, band)
        self._fold_inside = np.flatnonzero(mirror < band)
        self._fold_mirror = mirror[self._fold_inside]
        self._pulse_shapes: dict[float, np.ndarray] = {}

    def _synthesise_hit(
        self, hit_time_s: float, tip: str, pulses: list[_Pulse], double: bool, on_demand: bool
    ) -> SimulatedHit:
        """Compute one impact's force and response records and queue them for overlap-add into the stream."""
        fs = self.sample_rate_hz
        start_index = int(np.floor(hit_time_s * fs)) - PRE_HIT_SAMPLES
        offset_s = hit_time_s - start_index / fs
        s = self._s
        force_spectrum = sum(
            p.peak_force_n * self._pulse_shape(p.width_s) * np.exp(-s * (offset_s + p.delay_s)) for p in pulses
        )
        band = self._chain.shape[1]
        if self._responses == 1:
            acceleration_spectrum = self.plant.acceleration_spectrum(force_spectrum, s, 2 * fs, hit_time_s)
            measured = np.stack([force_spectrum[:band], acceleration_spectrum[:band]]) * self._chain
        else:  # one row per accelerometer, each through the acceleration channels' chain
            spectra = self.plant.acceleration_spectra(force_spectrum, s, 2 * fs, hit_time_s)
            measured = np.concatenate([force_spectrum[np.newaxis, :band] * self._chain[0],
                                       spectra[:, :band] * self._chain[1]])
        records = scipy.fft.irfft(self._fold_to_sample_rate(measured), self._segment_samples, axis=-1)
        self._contributions.append((start_index, records))
        hit = SimulatedHit(hit_time_s, max(p.peak_force_n for p in pulses), tip, double,
                           overload=self._overload_next_hit, on_demand=on_demand)
        self._overload_next_hit = False
        self._hits.append(hit)
        return hit

    def _pulse_shape(self, width_s: float) -> np.ndarray:
        """The half-sine pulse spectrum of one tip on the synthesis grid, computed once per start."""
        shape = self._pulse_shapes.get(width_s)
        if shape is None:
            shape = self._pulse_shapes[width_s] = half_sine_spectrum(self._freq_hz, width_s)
        return shape

    def _fold_to_sample_rate(self, spectra: np.ndarray) -> np.ndarray:
        """rfft (length ``n_out``) of every 2nd sample of signals (rows) given on the ×2 grid (bins ``k·fs/n_out``).

        Decimating by 2 folds bin ``k`` with the mirror of bin ``n_out − k``: ``X_d[k] = (X[k] + conj X[n_out−k])/2``,
        scaled ×2 back because the ×2 grid's inverse transform is normalised by ``2·n_out``.
        """
        folded = np.zeros((spectra.shape[0], self._segment_samples // 2 + 1), dtype=complex)
        folded[:, : self._fold_kept] = spectra[:, : self._fold_kept]
        folded[:, self._fold_inside] += np.conj(spectra[:, self._fold_mirror])
        return folded

    def _schedule_hits_until(self, end_index: int) -> None:
        """Synthesise every automatic hit whose record starts before sample ``end_index``."""
        fs = self.sample_rate_hz
        while self._next_auto_time_s is not None and self._next_auto_time_s * fs - PRE_HIT_SAMPLES < end_index:
            pulses, double = self._draw_pulses(self._schedule_rng, self.tip, None)
            self._synthesise_hit(self._next_auto_time_s, self.tip, pulses, double, on_demand=False)
            self._next_auto_time_s += self._schedule_rng.uniform(*self.hit_interval_s)

    def _generate(self, out: np.ndarray) -> np.ndarray:
        """Produce the next ``out.shape[1]`` samples of every channel; returns the per-channel overload flags."""
        n_samples = out.shape[1]
        first, end = self._position, self._position + n_samples
        self._schedule_hits_until(end)
        physical = np.zeros((self._responses + 2, n_samples))  # hammer, response(s), nothing
        remaining = []
        for start_index, records in self._contributions:
            lo, hi = max(start_index, first), min(start_index + records.shape[1], end)
            if lo < hi:
                physical[: records.shape[0], lo - first : hi - first] += records[:, lo - start_index : hi - start_index]
            if start_index + records.shape[1] > end:
                remaining.append((start_index, records))
        self._contributions = remaining
        # channels that carry the same signal through the same sensor kind, in the same filter state (several
        # accelerometers on a plant with one response), read the same volts until their own noise is added: each
        # distinct one is computed once
        distinct, position, distinct_rows_of_kind = self._channel_groups()
        volts = physical[self._signal_of_channel[distinct]]
        time_s = np.arange(first, end) / self.sample_rate_hz
        for name, rows in distinct_rows_of_kind.items():
            interference = self.plant.interference(name, time_s)
            if interference is not None:
                volts[rows] += interference
        volts *= self._true_v_per_si[distinct, np.newaxis]
        volts[self._open_sensor[distinct]] = 0.0
        volts = self._ac_coupled(volts, distinct, position)
        if self._noise_rms_v is not None:
            noise = physical[0]  # the stream's signals are in volts now: a scratch row
            for row, rng in enumerate(self._noise_rngs):
                rng.standard_normal(out=noise)
                noise *= self._noise_rms_v[row]
                volts[row] += noise
        overload = (volts.max(axis=1) > NI9234_INPUT_RANGE_V) | (volts.min(axis=1) < -NI9234_INPUT_RANGE_V)
        np.clip(volts, CODE_MIN_V, CODE_MAX_V, out=volts)
        if self.quantize:
            volts /= LSB_V
            np.round(volts, out=volts)
            volts *= LSB_V
        np.divide(volts, self._configured_v_per_si[:, np.newaxis], out=out)
        self._position = end
        return overload

    def _channel_groups(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """The channels that give the same volts before their noise: the first channel of each group (``distinct``),
        each channel's group (``position``) and, per sensor kind, the groups of that kind. A group is one signal
        through one sensor kind and sensitivity, open or not, in one AC-coupling filter state; the groups are formed
        again only when a sensor opens or closes (a member that left its group keeps its own filter state)."""
        open_now = self._open_sensor.tobytes()
        if self._filter_groups is None or self._filter_groups[0] != open_now:
            leaders: dict[tuple, int] = {}
            source = np.array([
                leaders.setdefault((self._signal_of_channel[row], self._channel_kinds[row], self._true_v_per_si[row],
                                    bool(self._open_sensor[row]), float(self._hp_state[row, 0])), row)
                for row in range(len(self._channel_kinds))
            ])
            distinct, position = np.unique(source, return_inverse=True)
            kinds = np.array(self._channel_kinds)[distinct]
            rows_of_kind = {name: np.flatnonzero(kinds == name) for name in self._rows_of_channel_kind}
            self._filter_groups = (open_now, distinct, position, rows_of_kind)
        return self._filter_groups[1:]

    def _ac_coupled(self, volts: np.ndarray, distinct: np.ndarray, position: np.ndarray) -> np.ndarray:
        """The AC-coupling high-pass on the volts of each channel group (groups × samples; :meth:`_channel_groups`),
        its state carried across chunks; returns every channel's filtered volts (channels × samples)."""
        filtered, state = scipy.signal.lfilter(self._hp_b, self._hp_a, volts, axis=1, zi=self._hp_state[distinct])
        self._hp_state = state[position]
        return filtered[position]

    def _wait_for(self, n_samples: int, timeout_s: float) -> None:
        """Realtime pacing: overflow if the unread backlog exceeds the buffer, else wait until the samples exist
        (times in signal seconds, :attr:`speed` of them per second; ``timeout_s`` in seconds)."""
        fs = self.sample_rate_hz
        now = time.monotonic()
        acquired_s = (now - self._started_wall_s) * self.speed
        backlog_s = acquired_s - self._position / fs
        if backlog_s > self.buffer_s * self.speed:
            self._fault = BufferOverflowError(
                f"sim: {backlog_s:.1f} s of unread samples exceeded the {self.buffer_s * self.speed:g} s device "
                f"buffer; the reader fell behind (DAQmx -200361)"
            )
            raise self._fault
        ready_at = self._started_wall_s + (self._position + n_samples) / fs / self.speed
        wait_s = ready_at - now
        if wait_s > timeout_s:
            time.sleep(timeout_s)
            raise ReadTimeoutError(
                f"sim: {n_samples} samples did not arrive within {timeout_s:g} s (DAQmx -200284)"
            )
        if wait_s > 0:
            time.sleep(wait_s)
