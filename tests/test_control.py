"""The identified film in control design: rational models within a stated error, stable and passive; exports loaded
with SciPy and python-control; the time-domain check against the recorded hits; ``gasfilm model``'s errors."""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np
import pytest
import scipy.io
import scipy.signal

from gasfilm.analysis.control.export import model_to_dict
from gasfilm.analysis.control.fitting import PoleResidue, oustaloup_response, vector_fit
from gasfilm.analysis.control.inputs import load_source
from gasfilm.analysis.control import rational
from gasfilm.analysis.control.rational import PlantSource, approximate, build_model, oustaloup_order
from gasfilm.analysis.control.timedomain import frf_relative_error, spec_of_fit, time_domain_check
from gasfilm.analysis.identification import FitResult
from gasfilm.analysis.physics.elements import PAPER_MODEL_ORDER, PAPER_MODELS, PAPER_TABLE1, accelerance
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.app.commands.common import load_frf
from test_cli_acquire_replay import gasfilm

MAX_ERROR = 0.005
SIM = ["--device", "sim", "--pacing", "fast", "--rate", "6400", "--record-s", "0.5", "--hit-interval", "0.6", "0.8"]


@pytest.fixture(scope="module")
def fitted_session(tmp_path_factory) -> Path:
    """A simulated FOMGF session (4 hits, 0.5 s records at 6400 S/s) with all nine paper models fitted."""
    from gasfilm.app import cli

    path = tmp_path_factory.mktemp("control") / "fomgf.h5"
    assert cli.main([*["acquire"], *SIM, "--out", str(path), "--hits", "4", "--seed", "2"]) == 0
    assert cli.main(["fit", str(path), "--models", "all", "--json"]) == 0
    return path


def _fits(path: Path) -> dict[str, FitResult]:
    with Session.open(path) as session:
        return {name: FitResult.from_dict(session.read_fit(name)) for name in session.result_names("fits")}


def dense_grid_error(model, lines: int = 200_000) -> tuple[float, float]:
    """The largest plant-or-film error of ``model`` on ``lines`` log-spaced lines over its band and over the decade
    beyond each side: a check of the stated errors independent of how they were found."""
    def largest(low: float, high: float, count: int) -> float:
        worst = 0.0
        for chunk in np.array_split(np.geomspace(low, high, count), max(1, count // 50_000)):
            plant, film = rational._relative_errors(model.source, model.static_stiffness_n_per_m, model.impedance,
                                                    chunk)
            worst = max(worst, float(plant.max()), float(film.max()))
        return worst

    low, high = model.band_hz
    inside = largest(low, high, lines)
    outside = max(largest(low / 10, low, lines // 4), largest(high, 10 * high, lines // 4))
    return inside, outside


def assert_stated_errors_are_not_below_the_dense_grid(model) -> None:
    inside, outside = dense_grid_error(model)
    assert model.max_error_band >= inside, (model.summary(), inside)
    assert model.max_error_outside >= outside, (model.summary(), outside)


# --- the approximation ---------------------------------------------------------------------------------------------


def test_vector_fit_recovers_a_rational_function_exactly():
    poles = np.array([-30.0, -200.0 + 900.0j, -200.0 - 900.0j])
    residues = np.array([5.0, 40.0 - 7.0j, 40.0 + 7.0j])
    exact = PoleResidue(poles, residues, 0.3)
    s = 2j * np.pi * np.geomspace(0.5, 5000, 300)
    fit = vector_fit(s, exact(s), 3, weight=1 / np.abs(exact(s)))
    assert np.max(np.abs(fit(s) / exact(s) - 1)) < 1e-10
    assert np.allclose(np.sort_complex(fit.poles), np.sort_complex(poles), rtol=1e-8)


def test_oustaloup_is_accurate_inside_its_band_only():
    s = 2j * np.pi * np.geomspace(10, 1000, 50)
    approx = oustaloup_response(0.5, (2 * np.pi * 0.1, 2 * np.pi * 1e5), 8, s)
    assert np.max(np.abs(approx / s**0.5 - 1)) < 0.01
    narrow = oustaloup_response(0.5, (2 * np.pi * 10, 2 * np.pi * 1000), 8, s)
    assert np.max(np.abs(narrow / s**0.5 - 1)) > 0.05  # the edges of its own band are poor: why it is widened


@pytest.mark.parametrize("name", ["FOMGF", "Zener"])
def test_table1_films_meet_the_error_stable_and_passive(name):
    model = approximate(PlantSource.from_spec(RigSpec.nominal(name)), max_error=MAX_ERROR)
    assert model.max_error_band <= MAX_ERROR
    assert_stated_errors_are_not_below_the_dense_grid(model)
    assert model.stable and model.passive.passed and not model.passive.crossings_hz
    # the state-space realisation is what the errors were measured on
    freq_hz = np.geomspace(*model.band_hz, 60)
    exact = accelerance(PAPER_MODELS[name], PAPER_TABLE1[name], freq_hz, 25.05)
    assert np.max(np.abs(model.accelerance(2j * np.pi * freq_hz) / exact - 1)) <= MAX_ERROR


def test_an_undamped_resonance_is_stated_as_missed_not_hidden_between_grid_lines():
    """Table 1's FOZGF film (ERRATA item 5: a row with errors) has a loss factor of 1e-16 at its 2159 Hz resonance
    under 25.05 kg: a peak 1e-4 Hz wide that no rational model follows to 0.5 %. The order a 40-lines-per-decade
    grid had called within 0.128 % (2 states) is stated far beyond it, where it misses."""
    model = approximate(PlantSource.from_spec(RigSpec.nominal("FOZGF")), order=2)
    assert model.max_error_band > 10 * MAX_ERROR
    assert model.error_grid["worst_band_hz"] == pytest.approx(2159.1, abs=0.1)
    assert_stated_errors_are_not_below_the_dense_grid(model)


def test_fixed_order_gives_that_many_states_and_more_states_fit_better():
    source = PlantSource.from_spec(RigSpec.nominal("FOMGF"))
    errors = []
    for order in (3, 5, 7):
        model = approximate(source, order=order)
        assert model.order == order
        assert_stated_errors_are_not_below_the_dense_grid(model)
        errors.append(model.max_error_band)
    assert errors[0] > errors[1] > errors[2]


def test_plain_oustaloup_needs_many_more_states():
    source = PlantSource.from_spec(RigSpec.nominal("FOMGF"))
    model = approximate(source, max_error=MAX_ERROR)
    oustaloup, error, _widen = oustaloup_order(source, model.band_hz, MAX_ERROR)
    assert oustaloup is not None and error <= MAX_ERROR
    assert oustaloup > 3 * model.order


def test_passivity_check_finds_a_film_that_returns_energy():
    """An impedance with a negative-damping resonance (Re Y < 0 around 1200 rad/s) is caught by the grid and by the
    Hamiltonian test, which names where the real part crosses zero; a Zener film's fit is passive."""
    bad = PoleResidue(np.array([-200.0 + 1200.0j, -200.0 - 1200.0j]), np.array([-3e5 + 0j, -3e5 + 0j]), 500.0)
    a, b, c, d = bad.state_space()
    omega = 2 * np.pi * np.geomspace(0.01, 1e6, 2000)
    check = rational._positive_real(a, b, c, d, lambda w: bad(1j * w).real, omega, 1e4)
    assert not check.passed and check.grid_minimum < 0 and len(check.crossings_hz) == 2
    assert all(100 < f < 300 for f in check.crossings_hz)  # around 1200 rad/s = 191 Hz
    good = PoleResidue(bad.poles, -bad.residues, 500.0)
    assert rational._positive_real(*good.state_space(), lambda w: good(1j * w).real, omega, 1e4).passed
    assert build_model(PlantSource.from_spec(RigSpec.nominal("Zener")), (2.0, 10000.0), 1).passive.passed


def test_negative_storage_of_the_fractional_film_is_reported_not_hidden():
    """FOBGF's Table 1 film has Re Z < 0 somewhere (an order above 1): the rational model follows it, says so, and
    says the fractional film does too; it still dissipates (passive)."""
    model = approximate(PlantSource.from_spec(RigSpec.nominal("FOBGF")), max_error=MAX_ERROR)
    assert_stated_errors_are_not_below_the_dense_grid(model)
    assert not model.storage.passed and model.source_storage_minimum < 0
    assert model.passive.passed and model.stable
    assert "so is the fractional film's" in model.summary()


def _fomgf_fit(params: dict[str, float]) -> FitResult:
    fit = _table1_fit("FOMGF")
    fit.params = dict(params)
    return fit


#: FOMGF fits whose second arm was a spare: an inertance on a spring, a narrow resonance between the FRF's lines
#: (issue 31: 298.8 Hz, and 19.9 Hz at the band's edge); the stated errors were 0.133 % and 0.137 %
NARROW_FEATURES = {
    "300 Hz": {"k3": 3.27e7, "k1": 354.0, "eta1": 1e-4, "alpha": 1.999, "k2": 2.91e6, "eta2": 16.14, "beta": 1.7472},
    "20 Hz": {"k3": 3.27e7, "k1": 1.03e5, "eta1": 6.57, "alpha": 1.996, "k2": 2.91e6, "eta2": 16.14, "beta": 1.7472},
}


@pytest.mark.parametrize("feature", NARROW_FEATURES)
def test_stated_error_of_a_film_with_a_narrow_resonance_is_where_the_error_is_largest(feature):
    """The error is measured on a grid that resolves every near-singular frequency of the fractional film and every
    pole and zero of the rational one, its maxima refined: the stated error is at least the error on a dense grid,
    in and out of band, and the model exported names where it is largest and how it was found."""
    source = PlantSource.from_fit(_fomgf_fit(NARROW_FEATURES[feature]))
    centre_hz = float(feature.split()[0])
    for model in (approximate(source, max_error=MAX_ERROR), approximate(source, order=6)):
        assert_stated_errors_are_not_below_the_dense_grid(model)
        inside, outside = dense_grid_error(model)
        assert model.max_error_band <= 1.001 * inside  # found, not overstated
        assert model.max_error_outside <= 1.001 * outside
        # the feature is where a coarse grid (the 40 lines per decade the error was measured on) misses it
        coarse = np.geomspace(*model.band_hz, int(40 * np.log10(model.band_hz[1] / model.band_hz[0])) + 1)
        plant, film = rational._relative_errors(source, model.static_stiffness_n_per_m, model.impedance, coarse)
        assert max(plant.max(), film.max()) < 0.5 * inside, model.summary()
        assert model.error_grid["worst_band_hz"] == pytest.approx(centre_hz, rel=0.05)
        assert any(abs(f / centre_hz - 1) < 0.05 for f in model.error_grid["resolved_fractional_hz"])
        data = model_to_dict(model)
        assert data["error_grid"]["method"].startswith("complex relative errors on a log grid")
        assert data["error_grid"]["base_lines_per_decade"] == rational.ERROR_LINES_PER_DECADE
    assert model.max_error_band > MAX_ERROR  # order 6 does not reach the target: said, not hidden


def test_rig_spec_names_what_the_linear_plant_leaves_out(tmp_path):
    loaded = load_source(Path(__file__).parents[1] / "fixtures" / "rigs" / "all-effects.toml", None)
    text = " ".join(loaded.plant.excluded)
    for effect in ("cubic-stiffness", "channel-delay", "mains", "drift"):
        assert effect in text
    assert loaded.plant.mass_kg == pytest.approx(25.05 + 0.12)  # the added mass is part of the plant


# --- acceptance on a simulated FOMGF session -----------------------------------------------------------------------


@pytest.mark.slow
def test_nine_fitted_models_rational_within_half_percent_stable_passive(fitted_session):
    fits = _fits(fitted_session)
    assert set(fits) == set(PAPER_MODEL_ORDER)
    for name, fit in fits.items():
        model = approximate(PlantSource.from_fit(fit), max_error=MAX_ERROR)
        assert model.band_hz == pytest.approx((fit.band_hz[0] / 10, fit.band_hz[1] * 10))
        assert model.max_error_band <= MAX_ERROR, (name, model.summary())
        assert_stated_errors_are_not_below_the_dense_grid(model)
        assert model.stable and model.passive.passed, (name, model.summary())
        assert 2 <= model.order <= 12, (name, model.summary())


@pytest.mark.slow
def test_exports_load_in_scipy_and_python_control(fitted_session, tmp_path, capsys):
    mat, js, npz = tmp_path / "fomgf.mat", tmp_path / "fomgf.json", tmp_path / "fomgf.npz"
    for path in (mat, js, npz):
        status, out, err = gasfilm(capsys, "model", fitted_session, "--model", "FOMGF", "--out", path)
        assert status == 0, err
    assert "order 5" in out and "stable, film passive" in out and "Oustaloup" in out
    fit = _fits(fitted_session)["FOMGF"]
    freq_hz = np.geomspace(fit.band_hz[0], fit.band_hz[1], 200)
    exact = fit.accelerance(freq_hz, decay_rate_1_s=0.0)
    omega = 2 * np.pi * freq_hz

    loaded = scipy.io.loadmat(mat)
    plant = scipy.signal.StateSpace(loaded["A"], loaded["B"], loaded["C"], loaded["D"])
    response = scipy.signal.freqresp(plant, omega)[1]
    assert np.max(np.abs(response / exact - 1)) <= MAX_ERROR
    assert np.all(np.linalg.eigvals(loaded["A"]).real < 0)

    data = json.loads(js.read_text())
    assert data["units"]["input"].startswith("force") and data["film_passive"]["passed"] and data["stable"]
    space = data["state_space"]
    system = control.ss(space["A"], space["B"], space["C"], space["D"])
    assert np.max(np.abs(system(1j * omega) / exact - 1)) <= MAX_ERROR
    transfer = control.tf(data["transfer_function"]["num"], data["transfer_function"]["den"])
    assert np.max(np.abs(transfer(1j * omega) / exact - 1)) <= MAX_ERROR
    assert data["origin"]["fit"]["model_name"] == "FOMGF" and data["order"] == system.nstates

    with np.load(npz) as arrays:
        assert np.array_equal(arrays["A"], loaded["A"]) and json.loads(str(arrays["metadata"]))["stable"]
    for path in (mat, js, npz):  # each format its own figures (issue 32: x.json was refused for x.mat's figure)
        assert (tmp_path / f"{path.name}-error.png").stat().st_size > 0
        assert (tmp_path / f"{path.name}-hits.png").stat().st_size > 0


@pytest.mark.slow
def test_time_domain_fractional_and_rational_against_the_recorded_hits(fitted_session):
    loaded = load_source(fitted_session, "FOMGF")
    frf = load_frf([fitted_session])[0]
    fit = loaded.fit
    model = approximate(loaded.plant, max_error=MAX_ERROR)
    frf_error = frf_relative_error(fit, frf.freq_hz, frf.h1)
    check = time_domain_check(spec_of_fit(fit), model, loaded.records, loaded.sample_rate_hz,
                              loaded.force_channel, loaded.response_channel, loaded.hit_indices,
                              loaded.trigger_index, frf_error, band_hz=fit.band_hz)
    assert len(check.hit_indices) == 4 and check.band_hz == fit.band_hz
    assert np.all(check.rational_vs_fractional <= MAX_ERROR)
    # in the band the model was fitted in, each hit's raw RMS error (sensor noise included) is within 2× the FRF
    # fit's relative error
    assert np.all(check.error_fractional <= 2 * frf_error), check.summary_lines()
    assert np.all(check.error_rational <= 2 * frf_error), check.summary_lines()
    # most of it is the sensor noise, measured as the residual where the response has decayed
    assert np.all(np.isfinite(check.noise_floor)) and np.all(check.noise_floor > 0.5 * check.error_fractional)
    assert np.all(check.excess_fractional <= frf_error), check.summary_lines()
    # over the whole alias-free band the sensor's broadband noise dominates: the error there is larger
    assert np.all(check.alias_free_error_fractional > check.error_fractional)
    # the check can fail: the spring-damper fit of the same hits is far beyond the noise
    sd = load_source(fitted_session, "SD")
    sd_check = time_domain_check(spec_of_fit(sd.fit), approximate(sd.plant), sd.records, sd.sample_rate_hz)
    assert np.all(sd_check.excess_fractional > 5 * frf_error)


# --- the command's one-line errors ---------------------------------------------------------------------------------


@pytest.mark.parametrize("flags, message", [
    (["--out", "x.txt"], "name a .json, .mat or .npz file"),
    (["--out", "x.json", "--order", "0"], "--order 0"),
    (["--out", "x.json", "--max-error", "abc"], "--max-error 'abc'"),
    (["--out", "x.json", "--band", "10:1"], "--band '10:1'"),
    (["--out", "x.json", "--model", "FOMGF"], "is a rig spec"),
])
def test_bad_flags_are_one_line(flags, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    spec = Path(__file__).parents[1] / "fixtures" / "rigs" / "fomgf.toml"
    status, out, err = gasfilm(capsys, "model", spec, *flags)
    assert status == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "x.json").exists()


def test_fit_json_needs_a_model_it_holds(tmp_path, capsys):
    fit = tmp_path / "fit.json"
    fit.write_text(json.dumps({"fits": [{"model_name": "SD"}, {"model_name": "FOMGF"}]}))
    status, _, err = gasfilm(capsys, "model", fit, "--out", tmp_path / "m.json")
    assert status == 2 and "holds several fits" in err
    status, _, err = gasfilm(capsys, "model", fit, "--model", "BGF", "--out", tmp_path / "m.json")
    assert status == 2 and "holds no fit of it" in err
    status, _, err = gasfilm(capsys, "model", fit, "--model", "SD", "--out", tmp_path / "m.json")
    assert status == 2 and "not a gasfilm fit" in err and len(err.strip().splitlines()) == 1


def test_rig_spec_to_mat_and_existing_output_refused(tmp_path, capsys):
    spec = Path(__file__).parents[1] / "fixtures" / "rigs" / "fomgf.toml"
    out = tmp_path / "plant.mat"
    status, text, err = gasfilm(capsys, "model", spec, "--out", out, "--max-error", "0.1%")
    assert status == 0, err
    assert scipy.io.loadmat(out)["max_error_band"].item() <= 0.001
    status, _, err = gasfilm(capsys, "model", spec, "--out", out)
    assert status == 2 and "exists already" in err


# --- the GUI's Identify tab and the report -------------------------------------------------------------------------


def _table1_fit(name: str) -> FitResult:
    return FitResult.from_dict({
        "model_name": name, "network": PAPER_MODELS[name].text, "params": PAPER_TABLE1[name], "std_errors": {},
        "correlation": [], "correlation_names": [], "rms": 1e-4, "peak_error": 1e-4, "evaluations": 1,
        "wall_time_s": 0.0, "method": "default", "flags": [], "band_hz": [20.0, 1000.0], "mass_kg": 25.05,
        "mass_fitted": False, "decay_rate_1_s": 0.0, "n_points": 100})


def test_identify_tab_shows_the_error_curve_and_exports_the_selected_model(qtbot, tmp_path):
    from gasfilm.analysis.identification import compare_models
    from gui_driving import open_window

    window = open_window(qtbot, tmp_path)
    try:
        controller, tab = window.controller, window.identify_tab
        fits = {name: _table1_fit(name) for name in ("SD", "FOMGF")}
        freq_hz = np.linspace(20, 1000, 100)
        controller.fits = fits
        controller.comparison = compare_models(list(fits.values()), freq_hz, fits["FOMGF"].accelerance(freq_hz))
        controller.fits_changed.emit()
        assert tab.table.item(0, 1).text() == "FOMGF"  # selected: the best
        model = tab.show_control_model()
        assert model is not None and model.order == 5
        assert "order 5" in tab.control_label.text() and "passive" in tab.control_label.text()
        curves = tab.control_plot.getPlotItem().listDataItems()
        assert len(curves) == 3 and np.max(curves[0].yData[(curves[0].xData >= 2) & (curves[0].xData <= 1e4)]) < 0.5
        written = tab.export_control_model(tmp_path / "plant.mat")
        assert written == tmp_path / "plant.mat"
        assert scipy.io.loadmat(written)["A"].shape == (5, 5)
        assert tab.export_control_model(tmp_path / "plant") == tmp_path / "plant.json"  # no suffix: JSON
    finally:
        window.controller.shutdown()


@pytest.mark.slow
def test_report_has_the_rational_models(fitted_session, tmp_path):
    from gasfilm.analysis.report import read_report_data, report_html

    page = report_html(read_report_data(fitted_session))
    section = page[page.index("<h2>Control design"):page.index("<h2>Diagnosis")]
    assert "<img alt='rational model error'" in section
    table = section[:section.index("<img")]
    assert table.count("<tr>") == 10 and "<td>FOMGF</td><td>5</td>" in table and ">NO<" not in table


def test_a_fit_with_impossible_values_is_one_line(tmp_path, capsys):
    fit = _table1_fit("FOMGF").to_dict()
    fit["params"]["k1"] = float("nan")
    path = tmp_path / "fit.json"
    path.write_text(json.dumps(fit))
    status, _, err = gasfilm(capsys, "model", path, "--out", tmp_path / "m.json")
    assert status == 2 and "k1 not finite" in err and len(err.strip().splitlines()) == 1


def test_model_order_beyond_the_limit_is_refused_and_a_high_order_simulates(tmp_path, capsys):
    """New-user trial, round 3: `model --order 200` was an internal LinAlgError; `--max-error 0.005` gave an order-9
    model whose time-domain check printed 'rational nan %' (the transfer-function route put a pole outside the unit
    circle). The simulation now runs mode by mode."""
    import numpy as np

    from gasfilm.analysis.control.timedomain import simulate_rational
    from gasfilm.drivers.errors import SettingError

    source = PlantSource.from_spec(RigSpec.nominal("FOMGF"))
    with pytest.raises(SettingError, match="--order 200: at most"):
        approximate(source, order=200)
    model = approximate(source, max_error=5e-5)  # the trial's 0.005 %: order 9
    force = np.zeros(6400)
    force[10:20] = 200.0 * np.sin(np.linspace(0, np.pi, 10))
    response = simulate_rational(model, force, 12_800.0)
    assert np.all(np.isfinite(response)) and np.max(np.abs(response)) < 100.0
