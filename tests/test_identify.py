"""Fitters, uncertainties, the Table-2 comparison, the figures and ``gasfilm fit``."""

import json
import logging
import math
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gasfilm.analysis.figures import figure18, figure19
from gasfilm.analysis.identification import (
    FitCancelledError,
    FitResult,
    GapsoSettings,
    best_by_bic,
    compare_models,
    fit_model,
    format_table2,
)
from gasfilm.analysis.identification.problem import Problem
from gasfilm.analysis.physics.elements import (
    PAPER_MASS_KG,
    PAPER_MODEL_ORDER,
    PAPER_MODELS,
    Dashpot,
    Parallel,
    Series,
    SpringPot,
    accelerance,
    get_model,
)
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import compute_frf
from gasfilm.app.cli import main as gasfilm
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2, default_hammer_and_accelerometer
from gasfilm.drivers.simulated import SimulatedNI9234

MASS_KG = PAPER_MASS_KG


def _element_kinds(node, kinds):
    if isinstance(node, (Parallel, Series)):
        for child in node.children:
            _element_kinds(child, kinds)
    elif isinstance(node, SpringPot):
        kinds[node.coefficient] = ("pot", node.order)
    elif isinstance(node, Dashpot):
        kinds[node.name] = ("dashpot", None)
    return kinds


def random_physical_frf(model, rng, points=240):
    """Random parameters giving one resonance of the 25.05 kg mover at 50–1000 Hz with damping ratio 0.005–0.3
    (orders uniform in 0.05–1.95, coefficients within ±2 decades of the resonance stiffness), and the noise-free
    accelerance on ``points`` lines from f_n/4 to 4·f_n."""
    kinds = _element_kinds(model.network, {})
    for _ in range(20000):
        fn_hz = math.exp(rng.uniform(math.log(50.0), math.log(1000.0)))
        wn = 2 * math.pi * fn_hz
        stiffness = MASS_KG * wn**2
        params = {p.name: rng.uniform(0.05, 1.95) for p in model.parameters if p.scale == "linear"}
        for p in model.parameters:
            if p.scale == "linear":
                continue
            kind, order = kinds.get(p.name, ("spring", None))
            value = stiffness * 10 ** rng.uniform(-2, 2)
            if kind == "dashpot":
                value /= wn
            elif kind == "pot":
                value /= wn ** params[order]
            params[p.name] = value
        z = model.stiffness(np.array([1j * wn]), params)[0]
        if not z.real > 0:
            continue
        scale = stiffness / z.real  # Z is homogeneous of degree one in the coefficients
        params = {n: v if n in {p.name for p in model.parameters if p.scale == "linear"} else v * scale
                  for n, v in params.items()}
        if not 0.005 <= z.imag / z.real / 2 <= 0.3:
            continue
        freq_hz = np.linspace(fn_hz / 4, fn_hz * 4, points)
        h = accelerance(model, params, freq_hz, MASS_KG)
        peak = int(np.argmax(np.abs(h)))
        inside = all(p.lower <= params[p.name] <= p.upper for p in model.parameters)
        if 0 < peak < points - 1 and 50.0 <= freq_hz[peak] <= 1000.0 and inside:
            return params, freq_hz, h
    raise AssertionError(f"no physical parameters found for {model.name}")


def noise_free_relative_rms(name: str, seeds: range) -> list[float]:
    """The default fitter's RMS over the peak |H| on noise-free FRFs of ``name`` (:func:`random_physical_frf`)."""
    model = PAPER_MODELS[name]
    relative_rms = []
    for seed in seeds:
        _, freq_hz, h = random_physical_frf(model, np.random.default_rng(1000 + seed))
        fit = fit_model(model, freq_hz, h, MASS_KG, seed=seed)
        relative_rms.append(fit.rms / np.max(np.abs(h)))
    return relative_rms


@pytest.mark.parametrize("name", PAPER_MODEL_ORDER)
def test_default_fitter_reaches_noise_free_frfs_in_20_of_20_seeds(name):
    relative_rms = noise_free_relative_rms(name, range(20))
    # the global optimum is exact; 1e-6 leaves room for the flat valleys where a nearly unidentifiable arm stalls
    assert max(relative_rms) <= 1e-6, [f"{r:.2e}" for r in relative_rms]


@pytest.mark.skipif(platform.machine() not in {"x86_64", "AMD64"}, reason="OpenBLAS kernel names are x86-64's")
def test_default_fitter_reaches_noise_free_frfs_with_another_blas_kernel():
    """FOTGF's fits with OpenBLAS forced to its AVX (Sandybridge) kernels, as on another CPU: the last bits of the
    arithmetic differ, and one search round missed FOTGF's optimum on seed 3 there (3.8e-6) while finding it here.
    (FOMGF, FOTGF and FOBGF at seeds 0-19 on the Haswell, Zen and Sandybridge kernels: 540 fits, all ≤ 1e-6 when
    this test was written; the suite keeps the case that failed.)"""
    script = (
        "import sys; sys.path.insert(0, sys.argv[1]); from test_identify import noise_free_relative_rms; "
        "print(max(noise_free_relative_rms('FOTGF', range(20))))"
    )
    env = {**os.environ, "OPENBLAS_CORETYPE": "Sandybridge", "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", script, str(Path(__file__).parent)], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert float(done.stdout.split()[-1]) <= 1e-6, done.stdout


def rig_frf(seed, hits=4, sample_rate_hz=2560.0, record_s=2.0, band_hz=(20.0, 800.0)):
    """H1 of on-demand hammer hits on the simulated paper rig (FOMGF film of Table 1, 25.05 kg, sensor and
    module noise)."""
    device = SimulatedNI9234(RigPlant.nominal("FOMGF"), seed=seed, pacing="fast", hit_interval_s=None)
    device.configure(default_hammer_and_accelerometer(sample_rate_hz))
    with device:
        device.start()
        records = device.sim_record_hits(hits, int(record_s * sample_rate_hz))
    return compute_frf(records, sample_rate_hz).band(*band_hz)


def test_fomgf_rig_frf_ranks_fomgf_with_the_best_at_e_over_80_percent():
    """On the paper's FOMGF rig the four fractional models reach the same RMS (FOTGF and FOBGF with an order at
    its bound, degenerating into FOMGF's shape): FOMGF ties with the best to 0.01 %, the integer models trail."""
    frf = rig_frf(seed=3)
    fits = [fit_model(PAPER_MODELS[name], frf.freq_hz, frf.h1, MASS_KG) for name in PAPER_MODEL_ORDER]
    rows = compare_models(fits, frf.freq_hz, frf.h1)
    by_name = {row.model_name: row for row in rows}
    assert by_name["FOMGF"].rms <= 1.0001 * rows[0].rms, format_table2(rows)
    assert {row.model_name for row in rows[:4]} == {"FOZGF", "FOMGF", "FOTGF", "FOBGF"}, format_table2(rows)
    assert by_name["FOMGF"].e_percent >= 80.0
    assert rows[-1].model_name == "SD" and rows[-1].e_percent == 0.0
    # the nested models: FOMGF contains FOZGF (one arm off) and Maxwell contains Zener
    assert by_name["FOMGF"].rms <= by_name["FOZGF"].rms * (1 + 1e-6)  # to the fitter's convergence tolerance
    assert by_name["Zener"].rms <= by_name["SD"].rms
    # ranked by RMS, but the best supported model is the lowest BIC, marked and named (before: the GUI called the
    # lowest RMS 'best (lowest BIC)')
    best = best_by_bic(rows)
    assert best.bic == min(row.bic for row in rows)
    table = format_table2(rows)
    assert f"* lowest BIC: {best.model_name}" in table
    assert [line.split()[1] for line in table.splitlines() if line.rstrip().endswith("*")
            or "*  " in line] == [best.model_name]


def test_fit_reports_rms_peak_error_uncertainties_and_round_trips():
    model = PAPER_MODELS["FOZGF"]
    params = {"k1": 3e6, "k2": 3.5e7, "eta1": 2e4, "alpha": 0.8}
    freq_hz = np.linspace(100.0, 400.0, 150)
    rng = np.random.default_rng(5)
    clean = accelerance(model, params, freq_hz, MASS_KG)
    noise = 1e-3 * np.max(np.abs(clean)) * (rng.standard_normal(150) + 1j * rng.standard_normal(150))
    fit = fit_model(model, freq_hz, clean + noise, MASS_KG)
    residual = clean + noise - fit.accelerance(freq_hz)
    assert fit.rms == pytest.approx(np.sqrt(np.mean(np.abs(residual) ** 2)), rel=1e-9)
    assert fit.peak_error == pytest.approx(np.max(np.abs(residual)), rel=1e-9)
    assert fit.rms < 1.2 * np.sqrt(np.mean(np.abs(noise) ** 2))
    assert fit.correlation.shape == (4, 4) and fit.correlation_names == model.parameter_names
    np.testing.assert_allclose(np.diag(fit.correlation), 1.0)
    for name, value in params.items():
        assert abs(fit.params[name] - value) <= 5 * fit.std_errors[name] + 1e-9 * value
    assert fit.evaluations > 0 and fit.wall_time_s > 0 and fit.method == "default"
    assert fit.band_hz == (100.0, 400.0) and fit.n_points == 150 and not fit.mass_fitted
    again = FitResult.from_dict(json.loads(json.dumps(fit.to_dict())))
    assert again.params == fit.params and again.flags == fit.flags
    np.testing.assert_allclose(again.accelerance(freq_hz), fit.accelerance(freq_hz))


def test_standard_errors_match_the_scatter_over_noise_realisations():
    model = PAPER_MODELS["SD"]
    params = {"k": 3.78e7, "eta": 3.45e3}
    freq_hz = np.linspace(120.0, 300.0, 120)
    clean = accelerance(model, params, freq_hz, MASS_KG)
    level = 2e-3 * np.max(np.abs(clean))
    rng = np.random.default_rng(9)
    fits = [
        fit_model(model, freq_hz, clean + level * (rng.standard_normal(120) + 1j * rng.standard_normal(120)), MASS_KG)
        for _ in range(40)
    ]
    for name in params:
        scatter = np.std([fit.params[name] for fit in fits], ddof=1)
        reported = np.mean([fit.std_errors[name] for fit in fits])
        assert 0.6 < reported / scatter < 1.6, (name, reported, scatter)


def test_over_parameterised_fit_is_flagged_as_found_and_reported_in_its_identifiable_form():
    """FOMGF on a spring-damper: as found, parameters the data cannot determine are flagged; as reported, the spare
    arm and the series spring are taken out (said in a note) and a spring beside a spring-pot of order 1 is left."""
    sd = PAPER_MODELS["SD"]
    freq_hz = np.linspace(100.0, 350.0, 200)
    h = accelerance(sd, {"k": 3.78e7, "eta": 3.45e3}, freq_hz, MASS_KG)
    h = h + 1e-4 * np.max(np.abs(h)) * np.random.default_rng(2).standard_normal(200)
    found = fit_model(PAPER_MODELS["FOMGF"], freq_hz, h, MASS_KG, reduce=False)
    assert any("not identifiable" in flag or "correlated" in flag or "bound" in flag for flag in found.flags)
    fit = fit_model(PAPER_MODELS["FOMGF"], freq_hz, h, MASS_KG)
    assert fit.rms <= 2e-4 * np.max(np.abs(h))
    assert fit.model_name == "FOMGF" and fit.reduced_from == PAPER_MODELS["FOMGF"].text
    assert fit.network == "k3 || pot(eta1, alpha)" and fit.params["alpha"] == pytest.approx(1.0, abs=1e-3)
    assert fit.notes[0].startswith("FOMGF reduces to k3 || pot(eta1, alpha) here: the branch k2 -- pot(eta2, beta) "
                                   "contributes below the noise")
    assert not any(flag.startswith("invented feature") for flag in fit.flags)
    clean = fit_model(sd, freq_hz, h, MASS_KG)
    assert not clean.flags and not clean.notes and not clean.reduced_from


def test_windowed_frf_is_fitted_with_the_windowed_model():
    model = PAPER_MODELS["FOZGF"]
    params = {"k1": 3e6, "k2": 3.5e7, "eta1": 2e4, "alpha": 0.8}
    freq_hz = np.linspace(80.0, 500.0, 200)
    sigma = 15.0
    h = accelerance(model, params, freq_hz, MASS_KG, decay_rate_1_s=sigma)
    windowed = fit_model(model, freq_hz, h, MASS_KG, decay_rate_1_s=sigma)
    plain = fit_model(model, freq_hz, h, MASS_KG)
    assert windowed.rms <= 1e-6 * np.max(np.abs(h))
    assert windowed.decay_rate_1_s == sigma
    assert plain.rms > 100 * windowed.rms
    for name, value in params.items():
        assert windowed.params[name] == pytest.approx(value, rel=1e-4)


@pytest.mark.parametrize("name", PAPER_MODEL_ORDER)
def test_fitter_jacobian_is_the_models_gradient_chained_through_the_coordinates(name):
    """The Levenberg–Marquardt Jacobian (mass fitted too) against central differences of the residual."""
    model = PAPER_MODELS[name]
    params, freq_hz, h = random_physical_frf(model, np.random.default_rng(77), points=60)
    problem = Problem(model, freq_hz, h, MASS_KG, 9.0, True, None, None)
    near_truth = problem.coords.from_params(model.vector(params), 1.05 * MASS_KG)
    theta = near_truth + np.random.default_rng(3).normal(0.0, 0.05, problem.coords.size)
    jacobian = problem.acc_jacobian(theta)
    rounding = 1e-8 * np.max(np.abs(problem.acc_residual(theta)))  # ≈ ε·|r|/step of the differences
    for i in range(problem.coords.size):
        step = np.zeros(problem.coords.size)
        step[i] = 1e-6
        column = (problem.acc_residual(theta + step) - problem.acc_residual(theta - step)) / 2e-6
        assert np.max(np.abs(column)) > 100 * rounding, (name, i)  # the column is resolved: the check can fail
        assert np.max(np.abs(jacobian[:, i] - column)) <= 1e-5 * np.max(np.abs(column)) + rounding, (name, i)


def test_a_parameter_at_its_bound_is_named_not_measured_and_marked_in_table_2(caplog):
    """A spring-damper fitted with the Zener model: the series spring k1 runs to its upper bound (1e12 N/m), as the
    search finds it (reported, the Zener reduces to SD's form: next test)."""
    freq_hz = np.linspace(100.0, 350.0, 200)
    h = accelerance(PAPER_MODELS["SD"], {"k": 3.78e7, "eta": 3.45e3}, freq_hz, MASS_KG)
    with caplog.at_level(logging.INFO, logger="gasfilm.analysis.identification"):
        zener = fit_model(PAPER_MODELS["Zener"], freq_hz, h, MASS_KG, reduce=False)
    logged = [record.getMessage() for record in caplog.records]
    assert logged[0].startswith("fit Zener (k2 || (k1 -- dashpot(eta1)), default fitter): 200 lines 100–350 Hz")
    assert f"{zener.evaluations} evaluations" in logged[-2]
    assert logged[-1] == "fit Zener: k1 ended at a bound (not measured)"
    assert zener.at_bound == ("k1",) and zener.params["k1"] == pytest.approx(1e12, rel=1e-6)
    assert set(zener.std_errors) == {"k2", "eta1"}
    assert any(flag.startswith("k1 at a bound") for flag in zener.flags)
    sd = fit_model(PAPER_MODELS["SD"], freq_hz, h * 1.001, MASS_KG)
    assert sd.at_bound == () and set(sd.std_errors) == {"k", "eta"}
    rows = compare_models([zener, sd], freq_hz, h)
    assert [row.at_bound for row in rows] == [("k1",), ()]
    lines = format_table2(rows).splitlines()
    assert "At bound" in lines[0] and lines[2].endswith("k1") and lines[3].endswith(f"{rows[1].bic:.1f}")
    again = FitResult.from_dict(json.loads(json.dumps(zener.to_dict())))
    assert again.at_bound == ("k1",) and again.std_errors == zener.std_errors


def test_a_series_spring_at_its_bound_is_taken_out_and_the_fit_named_by_its_form():
    freq_hz = np.linspace(100.0, 350.0, 200)
    h = accelerance(PAPER_MODELS["SD"], {"k": 3.78e7, "eta": 3.45e3}, freq_hz, MASS_KG)
    zener = fit_model(PAPER_MODELS["Zener"], freq_hz, h, MASS_KG)
    assert zener.network == "k2 || dashpot(eta1)" and zener.at_bound == () and set(zener.std_errors) == {"k2", "eta1"}
    assert zener.notes[0].startswith("Zener reduces to SD (k2 || dashpot(eta1)) here: k1 is too stiff to matter")
    assert zener.params["k2"] == pytest.approx(3.78e7, rel=1e-9) and zener.params["eta1"] == pytest.approx(3.45e3)
    again = FitResult.from_dict(json.loads(json.dumps(zener.to_dict())))
    assert again.notes == zener.notes and again.reduced_from == PAPER_MODELS["Zener"].text
    rows = compare_models([zener], freq_hz, h)
    assert rows[0].n_parameters == 2  # the parameters the data determine


def fomgf_rig_fits(seeds):
    """FOMGF fitted to the H1 of 4 hits of 1 s on the simulated paper FOMGF rig (seeds ``seeds``)."""
    return [fit_model(PAPER_MODELS["FOMGF"], frf.freq_hz, frf.h1, MASS_KG, seed=seed)
            for seed, frf in ((seed, rig_frf(seed, record_s=1.0)) for seed in seeds)]


def test_fomgf_rig_at_10_seeds_one_arm_order_no_invented_feature_parameters_within_their_uncertainty():
    """The paper's FOMGF rig: its second arm (η₂·s^β ≈ 300 N/m beside k₃ = 3.3e7 N/m) is below the noise. Every
    session reports FOMGF in the same identifiable form — FOZGF's, the film in arm 1 — with no parameter at a bound,
    no feature the FRF lacks (a spare arm used to become a narrow resonance between the lines), and each parameter
    within 3 standard errors of the others' weighted mean and of the rig's value: a campaign over these sessions shows
    no trend the dynamic stiffness does not have."""
    fits = fomgf_rig_fits(range(10))
    nominal = RigSpec.nominal("FOMGF").film_parameters
    for fit in fits:
        assert fit.network == "k3 || (k1 -- pot(eta1, alpha))", (fit.network, fit.params)
        assert fit.notes[0].startswith("FOMGF reduces to FOZGF (k3 || (k1 -- pot(eta1, alpha))) here: the branch "
                                       "k2 -- pot(eta2, beta) contributes below the noise"), fit.notes
        assert not fit.at_bound and not fit.flags, fit.flags
    for name in ("k3", "k1", "eta1", "alpha"):
        values = np.array([fit.params[name] for fit in fits])
        sigma = np.array([fit.std_errors[name] for fit in fits])
        mean = np.sum(values / sigma**2) / np.sum(1 / sigma**2)
        assert np.all(np.abs(values - mean) <= 3 * sigma), (name, values, sigma)
        assert abs(mean - nominal[name]) <= 3 * np.max(sigma), (name, mean, nominal[name])


def test_a_spare_arm_parked_at_the_resonance_is_taken_out_and_the_film_keeps_arm_1():
    """Relative noise (0.3 % of |H| on every line, as a coherence dip gives at the peak) on a film whose second arm
    the data do not resolve: in some sessions the spare arm parks as an absorber at the mover's resonance (an order
    near 2 on a few hundred N/m), a resonance narrower than the lines or below the noise that lowers the RMS by
    fitting the peak's noise. It is taken out all the same (said, with the RMS it costs) and the film stays in
    arm 1."""
    model = PAPER_MODELS["FOMGF"]
    truth = {"k3": 3e7, "k1": 6e6, "alpha": 0.75, "k2": 9e6, "beta": 0.65}
    truth["eta1"] = truth["k1"] / (2 * np.pi * 60) ** truth["alpha"]
    truth["eta2"] = truth["k2"] / (2 * np.pi * 500) ** truth["beta"]
    freq_hz = np.linspace(20.0, 1000.0, 491)
    clean = accelerance(model, truth, freq_hz, MASS_KG)
    fits = []
    for seed in (3, 6):  # as found, the spare arm is an absorber at the resonance in both
        rng = np.random.default_rng(seed)
        h = clean + 0.003 * np.abs(clean) * (rng.standard_normal(491) + 1j * rng.standard_normal(491))
        if seed == 3:  # as found: the spare arm an absorber (the test can fail)
            found = fit_model(model, freq_hz, h, MASS_KG, seed=seed, reduce=False)
            assert found.params["beta"] > 1.95 and found.params["k2"] < 1e3, found.params
        fit = fit_model(model, freq_hz, h, MASS_KG, seed=seed)
        assert fit.network == "k3 || (k1 -- pot(eta1, alpha))" and not fit.flags[1:], (fit.params, fit.flags)
        assert not any(flag.startswith("invented") for flag in fit.flags)
        fits.append(fit)
    # one film in arm 1 (a single arm for two: its values follow the noise more than its σ, not by decades)
    assert max(fit.params["k1"] for fit in fits) < 1.5 * min(fit.params["k1"] for fit in fits)
    assert np.ptp([fit.params["alpha"] for fit in fits]) < 0.1


def test_mass_can_be_fitted():
    model = PAPER_MODELS["Zener"]
    params = {"k1": 5e6, "k2": 3.8e7, "eta1": 4e3}
    freq_hz = np.linspace(60.0, 600.0, 200)
    h = accelerance(model, params, freq_hz, 24.0)
    fixed = fit_model(model, freq_hz, h, 26.0)
    fitted = fit_model(model, freq_hz, h, 26.0, fit_mass=True)
    assert fitted.mass_fitted and fitted.mass_kg == pytest.approx(24.0, rel=1e-6)
    assert "mass_kg" in fitted.std_errors and fitted.correlation.shape == (4, 4)
    assert fitted.rms <= 1e-6 * np.max(np.abs(h)) < fixed.rms


def test_gapso_is_seeded_converges_and_is_not_better_than_the_default():
    model = PAPER_MODELS["Zener"]
    params = {"k1": 5e6, "k2": 3.8e7, "eta1": 4e3}
    freq_hz = np.linspace(100.0, 350.0, 60)
    h = accelerance(model, params, freq_hz, MASS_KG)
    settings = GapsoSettings(population=40, swarm_size=10, candidates=3, max_generations=300, max_iterations=600)
    first = fit_model(model, freq_hz, h, MASS_KG, method="gapso", seed=4, gapso_settings=settings)
    again = fit_model(model, freq_hz, h, MASS_KG, method="gapso", seed=4, gapso_settings=settings)
    other = fit_model(model, freq_hz, h, MASS_KG, method="gapso", seed=5, gapso_settings=settings)
    default = fit_model(model, freq_hz, h, MASS_KG)
    assert first.params == again.params and first.evaluations == again.evaluations
    assert other.params != first.params
    assert first.method == "gapso" and first.rms < 0.05 * np.max(np.abs(h))
    # 50 unchanged generations then 50 unchanged swarm iterations at least; below both caps
    assert 50 * 38 + 50 * 30 <= first.evaluations < 300 * 38 + 600 * 30 + 100
    assert default.rms <= first.rms
    assert default.evaluations * 10 <= first.evaluations


def test_progress_and_cancel():
    model = PAPER_MODELS["FOZGF"]
    freq_hz = np.linspace(100.0, 400.0, 100)
    h = accelerance(model, {"k1": 3e6, "k2": 3.5e7, "eta1": 2e4, "alpha": 0.8}, freq_hz, MASS_KG)
    seen = []
    fit_model(model, freq_hz, h, MASS_KG, progress=seen.append)
    assert seen[-1] == 1.0 and all(0.0 <= f <= 1.0 for f in seen) and seen == sorted(seen)
    for method in ("default", "gapso"):
        with pytest.raises(FitCancelledError):
            fit_model(model, freq_hz, h, MASS_KG, method=method, cancel=lambda: True)


@pytest.mark.parametrize(
    "change, match",
    [
        ({"method": "newton"}, "fit method"),
        ({"mass_kg": -1.0}, "mass_kg"),
        ({"h_measured": np.full(50, np.nan + 0j)}, "non-finite"),
        ({"freq_hz": np.linspace(0.0, 10.0, 50)}, "0 Hz"),
        ({"freq_hz": np.linspace(1.0, 10.0, 49)}, "equal 1-D"),
        ({"weights": -np.ones(50)}, "weights"),
    ],
)
def test_bad_inputs_are_one_line_setting_errors(change, match):
    arguments = dict(
        model=PAPER_MODELS["SD"], freq_hz=np.linspace(50.0, 300.0, 50), h_measured=np.ones(50) * (1 + 1j),
        mass_kg=MASS_KG,
    )
    arguments.update(change)
    with pytest.raises(SettingError, match=match) as error:
        fit_model(**arguments)
    assert "\n" not in str(error.value)


def test_compare_models_is_table_2_with_aic_bic():
    freq_hz = np.linspace(100.0, 350.0, 120)
    h = accelerance(PAPER_MODELS["FOZGF"], {"k1": 3e6, "k2": 3.5e7, "eta1": 2e4, "alpha": 0.8}, freq_hz, MASS_KG)
    h = h + 1e-4 * np.random.default_rng(1).standard_normal(120)
    fits = [fit_model(PAPER_MODELS[name], freq_hz, h, MASS_KG) for name in ("SD", "Zener", "FOZGF")]
    rows = compare_models(fits, freq_hz, h)
    assert [row.rank for row in rows] == [1, 2, 3]
    assert rows[0].model_name == "FOZGF" and rows[-1].model_name == "SD"
    sd = next(fit for fit in fits if fit.model_name == "SD")
    for row in rows:
        fit = next(f for f in fits if f.model_name == row.model_name)
        residual = h - fit.accelerance(freq_hz)
        assert row.rms == pytest.approx(np.sqrt(np.mean(np.abs(residual) ** 2)))
        assert row.e_percent == pytest.approx(100 * (sd.rms - row.rms) / sd.rms, rel=1e-6, abs=1e-9)
        assert row.e_m_percent == pytest.approx(100 * (sd.peak_error - row.peak_error) / sd.peak_error, abs=1e-6)
        rss, n = np.sum(np.abs(residual) ** 2), 2 * len(freq_hz)
        assert row.aic == pytest.approx(n * math.log(rss / n) + 2 * len(fit.params))
        assert row.bic == pytest.approx(n * math.log(rss / n) + len(fit.params) * math.log(n))
    g_table, si_table = format_table2(rows, "g/N"), format_table2(rows, "SI")
    assert f"{rows[0].rms / STANDARD_GRAVITY_M_S2:.6g}" in g_table and f"{rows[0].rms:.6g}" in si_table
    assert "FOZGF" in g_table and "0.00%" in g_table
    without_sd = compare_models(fits[1:], freq_hz, h)
    assert all(row.e_percent is None for row in without_sd) and "—" in format_table2(without_sd)
    with pytest.raises(SettingError):
        format_table2(rows, "lbf")


def test_figures_18_and_19_are_png_files(tmp_path):
    freq_hz = np.linspace(100.0, 350.0, 80)
    h = accelerance(PAPER_MODELS["SD"], {"k": 3.78e7, "eta": 3.45e3}, freq_hz, MASS_KG)
    fits = [fit_model(PAPER_MODELS[name], freq_hz, h * 1.01, MASS_KG) for name in ("SD", "Zener")]
    for draw, name in ((figure18, "f18.png"), (figure19, "sub/f19.png")):
        path = draw(tmp_path / name, freq_hz, h, fits)
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


def _session_with_frf(tmp_path):
    from gasfilm.analysis.session import Session

    frf = rig_frf(seed=2, hits=3, band_hz=(0.0, 1280.0))
    path = tmp_path / "hammer.h5"
    spec = RigSpec.nominal("FOMGF")
    with Session.create(path, default_hammer_and_accelerometer(2560.0), spec.to_toml(), {}) as session:
        session.write_frf(frf)
    return path


def test_cli_fit_prints_table_writes_figures_and_stores_fits(tmp_path, capsys):
    from gasfilm.analysis.session import Session

    path = _session_with_frf(tmp_path)
    status = gasfilm(["fit", str(path), "--models", "SD,FOZGF", "--band", "50:600", "--out", str(tmp_path / "fig")])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "Table 2 (g/N;" in captured.out and "FOZGF" in captured.out  # the --units default
    assert gasfilm(["fit", str(path), "--models", "SD,FOZGF", "--band", "50:600", "--out", str(tmp_path / "fig"),
                    "--overwrite", "--units", "si"]) == 0
    assert "Table 2 ((m/s²)/N;" in capsys.readouterr().out
    assert "%" not in captured.err  # no progress bar off a terminal
    assert "Identified parameters" in captured.out and "alpha" in captured.out
    assert (tmp_path / "fig" / "hammer-figure18.png").exists() and (tmp_path / "fig" / "hammer-figure19.png").exists()
    with Session.open(path) as session:
        stored = session.read_fit("FOZGF")
    assert stored["model_name"] == "FOZGF" and stored["mass_kg"] == pytest.approx(MASS_KG)
    assert stored["band_hz"][0] >= 50.0 and stored["band_hz"][1] <= 600.0
    again = FitResult.from_dict(stored)
    assert again.model_name == "FOZGF" and set(again.params) == {"k1", "k2", "eta1", "alpha"}
    assert again.correlation.shape == (4, 4) and isinstance(again.flags, tuple)

    # SD is stored over 50–600 Hz: the default band replaces it only when asked
    status = gasfilm(["fit", str(path), "--models", "SD", "--json", "--out", str(tmp_path)])
    assert status == 2 and "holds a SD fit over" in capsys.readouterr().err
    status = gasfilm(["fit", str(path), "--models", "SD", "--json", "--out", str(tmp_path), "--overwrite"])
    document = json.loads(capsys.readouterr().out)
    assert status == 0 and document["fits"][0]["model_name"] == "SD" and document["table"][0]["e_percent"] == 0.0
    assert document["band_hz"][0] >= 20.0 and document["band_hz"][1] <= 1000.0


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--models", "SD,FOXGF"], "FOXGF"),
        (["--band", "600:50"], "--band"),
        (["--band", "abc"], "--band"),
        (["--band", "5000:6000"], "starts above 0.45·fs = 1152 Hz"),
        (["--band", "1000:1002"], "only 5 FRF lines"),
        (["--mass", "-3"], "--mass"),
    ],
)
def test_cli_fit_errors_are_one_line(tmp_path, capsys, arguments, message):
    path = _session_with_frf(tmp_path)
    status = gasfilm(["fit", str(path), *arguments])
    error = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(error) == 1 and message in error[0]


def test_get_model_accepts_the_names_the_cli_uses():
    assert get_model("fomgf") is PAPER_MODELS["FOMGF"]


def test_cli_fit_computes_the_frf_from_accepted_hits_with_the_sessions_window(tmp_path, capsys):
    from gasfilm.analysis.capture import HitRecord
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.spectra import WindowSettings
    from gasfilm.analysis.validation import Verdict

    rate_hz, samples = 2560.0, 5120
    device = SimulatedNI9234(RigPlant.nominal("FOMGF"), seed=4, pacing="fast", hit_interval_s=None)
    device.configure(default_hammer_and_accelerometer(rate_hz))
    buffer = np.empty((2, samples))
    window = WindowSettings(exponential_end_fraction=0.05)
    path = tmp_path / "hits.h5"
    with Session.create(path, device.config, RigSpec.nominal("FOMGF").to_toml(), {"window": window}) as session:
        with device:
            device.start()
            for index in range(3):
                device.sim_hit()
                device.read(buffer)
                hit = HitRecord(index, buffer.copy(), rate_hz, 0, 2.0 * index, overload=np.zeros(2, bool))
                session.append_hit(hit, Verdict(True))
    status = gasfilm(["fit", str(path), "--models", "SD,FOZGF", "--band", "50:600", "--json", "--out", str(tmp_path)])
    document = json.loads(capsys.readouterr().out)
    sigma = window.decay_rate_1_s(samples, rate_hz)
    assert status == 0 and document["decay_rate_1_s"] == pytest.approx(sigma)
    fozgf = next(fit for fit in document["fits"] if fit["model_name"] == "FOZGF")
    assert fozgf["decay_rate_1_s"] == pytest.approx(sigma)
    assert document["table"][0]["model_name"] == "FOZGF" and document["table"][0]["e_percent"] > 80.0


def test_the_latin_hypercube_is_scipys_bit_for_bit_without_importing_scipy_stats():
    """Issue 32 item 16: importing scipy.stats for its LatinHypercube was half of `gasfilm fit`'s start-up; the
    starts (and so every fit) are the same as before."""
    import subprocess
    import sys

    from scipy.stats import qmc

    from gasfilm.analysis.identification.default_search import latin_hypercube

    for seed in (0, 1, 7):
        for dimensions in (1, 3, 6):
            ours, theirs = np.random.default_rng(seed), np.random.default_rng(seed)
            for _ in range(2):  # and the generator goes on alike
                np.testing.assert_array_equal(latin_hypercube(dimensions, 40 * dimensions, ours),
                                              qmc.LatinHypercube(d=dimensions, seed=theirs).random(40 * dimensions))
            np.testing.assert_array_equal(ours.uniform(size=3), theirs.uniform(size=3))
    loaded = subprocess.run([sys.executable, "-c", "import sys, gasfilm.analysis.identification, "
                             "gasfilm.analysis.figures; print('scipy.stats' in sys.modules)"],
                            capture_output=True, text=True, check=True).stdout.strip()
    assert loaded == "False"


def test_an_undamped_branch_resonance_narrower_than_any_grid_is_a_feature_not_a_crash():
    """GUI fits that "never ended" (2026-11-29): a FOMGF fit whose second spring-pot ran to order 2 exactly (an
    undamped inertance on k2: a resonance √(k2/η2)/2π ≈ 21.8 Hz with no width) crashed the invented-feature check
    with an IndexError for about a third of these k2 — the peak refined between two samples above √2 × every sample — and
    the GUI's fit job failed. Each is one film resonance there, of zero width (narrower than any grid)."""
    from gasfilm.analysis.physics.elements import get_model
    from gasfilm.analysis.physics.features import film_features

    model = get_model("FOMGF")
    params = {"k3": 3.2466827e7, "k1": 2.9110842e6, "eta1": 16.157375, "alpha": 1.7471001, "eta2": 12.31745,
              "beta": 2.0}
    for k2 in np.linspace(2.30e5, 2.31e5, 60):
        resonance_hz = np.sqrt(k2 / params["eta2"]) / (2 * np.pi)
        features = film_features(model, {**params, "k2": float(k2)}, 25.0, (10.0, 2000.0))
        assert any(feature.kind == "film resonance" and abs(feature.freq_hz / resonance_hz - 1) < 1e-6
                   for feature in features), (k2, features)
