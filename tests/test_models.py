"""The model algebra against the paper's closed forms (eqs. 18–31 with ERRATA items 1–2) and the text form."""

import numpy as np
import pytest

from gasfilm.analysis.physics.elements import (
    PAPER_MODEL_ORDER,
    PAPER_MODELS,
    accelerance,
    get_model,
    log_laplace,
    parse_network,
)
from gasfilm.drivers.errors import SettingError

RTOL = 1e-12
C = np.cos
S = np.sin
HALF_PI = np.pi / 2


def _from_k_and_c(k_w, c_w, w):
    """Complex stiffness K* = k(w) + j·w·c(w) (eq. 19)."""
    return k_w + 1j * w * c_w


def _maxwell_arm_terms(k, eta, theta, w):
    """a_n, b_n, c_n, d_n of eqs. 21/24, with b and d read as real (ERRATA item 1)."""
    a = k + eta * w**theta * C(HALF_PI * theta)
    b = eta * w**theta * S(HALF_PI * theta)
    c = k * eta * w**theta * C(HALF_PI * theta)
    d = k * eta * w**theta * S(HALF_PI * theta)
    return a, b, c, d


def closed_fozgf(p, w):
    """Eqs. 18, 21, 22."""
    a1, b1, c1, d1 = _maxwell_arm_terms(p["k1"], p["eta1"], p["alpha"], w)
    k_w = p["k2"] + (a1 * c1 + b1 * d1) / (a1**2 + b1**2)
    c_w = ((a1 * d1 - b1 * c1) / (a1**2 + b1**2)) / w
    return _from_k_and_c(k_w, c_w, w)


def closed_fomgf(p, w):
    """Eqs. 23, 24, 25."""
    a1, b1, c1, d1 = _maxwell_arm_terms(p["k1"], p["eta1"], p["alpha"], w)
    a2, b2, c2, d2 = _maxwell_arm_terms(p["k2"], p["eta2"], p["beta"], w)
    k_w = p["k3"] + (a2 * c2 + b2 * d2) / (a2**2 + b2**2) + (a1 * c1 + b1 * d1) / (a1**2 + b1**2)
    c_w = ((a2 * d2 - b2 * c2) / (a2**2 + b2**2) + (a1 * d1 - b1 * c1) / (a1**2 + b1**2)) / w
    return _from_k_and_c(k_w, c_w, w)


def closed_fotgf(p, w):
    """Eqs. 26, 27 (cos/sin of π/2·(α+β), ERRATA item 2), 28."""
    k1, eta1, eta2, al, be = p["k1"], p["eta1"], p["eta2"], p["alpha"], p["beta"]
    a = k1 + eta1 * w**al * C(HALF_PI * al) + eta2 * w**be * C(HALF_PI * be)
    b = eta1 * w**al * S(HALF_PI * al) + eta2 * w**be * S(HALF_PI * be)
    c = k1 * eta2 * w**be * C(HALF_PI * be) + eta1 * eta2 * w ** (al + be) * C(HALF_PI * (al + be))
    d = k1 * eta2 * w**be * S(HALF_PI * be) + eta1 * eta2 * w ** (al + be) * S(HALF_PI * (al + be))
    k_w = (a * c + b * d) / (a**2 + b**2)
    c_w = ((a * d - b * c) / (a**2 + b**2)) / w
    return _from_k_and_c(k_w, c_w, w)


def closed_fobgf(p, w):
    """Eqs. 29, 30, 31."""
    k1, k2, eta1, eta2, al, be = p["k1"], p["k2"], p["eta1"], p["eta2"], p["alpha"], p["beta"]
    a = (
        k1 * k2
        + eta1 * eta2 * w ** (al + be) * C(HALF_PI * (al + be))
        + (k1 + k2) * eta1 * w**al * C(HALF_PI * al)
        + k1 * eta2 * w**be * C(HALF_PI * be)
    )
    b = (
        eta1 * eta2 * w ** (al + be) * S(HALF_PI * (al + be))
        + (k1 + k2) * eta1 * w**al * S(HALF_PI * al)
        + k1 * eta2 * w**be * S(HALF_PI * be)
    )
    c = k1 * eta1 * eta2 * w ** (al + be) * C(HALF_PI * (al + be)) + k1 * k2 * eta1 * w**al * C(HALF_PI * al)
    d = k1 * eta1 * eta2 * w ** (al + be) * S(HALF_PI * (al + be)) + k1 * k2 * eta1 * w**al * S(HALF_PI * al)
    k_w = (a * c + b * d) / (a**2 + b**2)
    c_w = ((a * d - b * c) / (a**2 + b**2)) / w
    return _from_k_and_c(k_w, c_w, w)


def closed_sd(p, w):
    """Spring–damper: K* = k + j·w·eta."""
    return _from_k_and_c(p["k"], p["eta"], w)


CLOSED_FORMS = {
    "SD": closed_sd,
    "FOZGF": closed_fozgf,
    "FOMGF": closed_fomgf,
    "FOTGF": closed_fotgf,
    "FOBGF": closed_fobgf,
}

#: classical model → (its FO form, the orders that turn the FO form into it)
ORDER_ONE = {
    "Zener": ("FOZGF", {"alpha": 1.0}),
    "Maxwell": ("FOMGF", {"alpha": 1.0, "beta": 1.0}),
    "TGF": ("FOTGF", {"alpha": 1.0, "beta": 1.0}),
    "BGF": ("FOBGF", {"alpha": 1.0, "beta": 1.0}),
}


def random_parameters(model, rng):
    """Coefficients log-uniform over 1e2…1e9, orders uniform over (0.05, 1.95)."""
    values = {}
    for parameter in model.parameters:
        if parameter.scale == "linear":
            values[parameter.name] = rng.uniform(0.05, 1.95)
        else:
            values[parameter.name] = 10 ** rng.uniform(2, 9)
    return values


def relative_error(actual, expected):
    return np.max(np.abs(actual - expected) / np.abs(expected))


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_stiffness_equals_the_papers_closed_form(name):
    rng = np.random.default_rng(sum(map(ord, name)))
    model = PAPER_MODELS[name]
    for _ in range(50):
        params = random_parameters(model, rng)
        freq_hz = rng.uniform(1.0, 5000.0, 64)
        w = 2 * np.pi * freq_hz
        z = model.stiffness(1j * w, params)
        assert relative_error(z, CLOSED_FORMS[name](params, w)) <= RTOL


@pytest.mark.parametrize("classical", sorted(ORDER_ONE))
def test_classical_models_are_their_fo_forms_at_order_one(classical):
    fractional, orders = ORDER_ONE[classical]
    rng = np.random.default_rng(sum(map(ord, classical)))
    for _ in range(50):
        params = random_parameters(PAPER_MODELS[classical], rng)
        w = 2 * np.pi * rng.uniform(1.0, 5000.0, 64)
        z_classical = PAPER_MODELS[classical].stiffness(1j * w, params)
        z_fractional = PAPER_MODELS[fractional].stiffness(1j * w, {**params, **orders})
        assert relative_error(z_classical, z_fractional) <= RTOL
        assert relative_error(z_classical, CLOSED_FORMS[fractional]({**params, **orders}, w)) <= RTOL


def test_fractional_orders_change_the_stiffness():
    """The order-one equality above is not vacuous: another order gives another stiffness."""
    params = {"k1": 3e6, "k2": 1.6e8, "eta1": 1e5, "alpha": 0.7}
    w = 2 * np.pi * np.array([50.0, 200.0])
    z_fractional = PAPER_MODELS["FOZGF"].stiffness(1j * w, params)
    z_zener = PAPER_MODELS["Zener"].stiffness(1j * w, {"k1": 3e6, "k2": 1.6e8, "eta1": 1e5})
    assert relative_error(z_fractional, z_zener) > 1e-3


def test_accelerance_is_equation_34_and_the_windowed_laplace_form():
    model = PAPER_MODELS["FOMGF"]
    rng = np.random.default_rng(7)
    params = random_parameters(model, rng)
    freq_hz = np.linspace(10.0, 1000.0, 200)
    w = 2 * np.pi * freq_hz
    mass_kg = 25.05
    z = closed_fomgf(params, w)
    expected = -(w**2) / (z.real - mass_kg * w**2 + 1j * z.imag)  # eq. 34 with k(w) and c(w)·w
    assert relative_error(accelerance(model, params, freq_hz, mass_kg), expected) <= 1e-10
    sigma = 12.5
    s = sigma + 1j * w
    windowed = s**2 / (model.stiffness(s, params) + mass_kg * s**2)
    assert relative_error(accelerance(model, params, freq_hz, mass_kg, decay_rate_1_s=sigma), windowed) <= RTOL
    assert relative_error(windowed, expected) > 1e-3


def test_evaluation_is_vectorised_over_parameter_sets():
    model = PAPER_MODELS["FOBGF"]
    rng = np.random.default_rng(3)
    sets = np.array([[model.vector(random_parameters(model, rng)) for _ in range(4)] for _ in range(3)])
    s = 2j * np.pi * np.linspace(5.0, 800.0, 37)
    together = model.stiffness(s, sets)
    assert together.shape == (3, 4, 37)
    for i in range(3):
        for j in range(4):
            np.testing.assert_array_equal(together[i, j], model.stiffness(s, sets[i, j]))


def central_differences(model, s, vector):
    """dZ/dθ (len(s), P) by central differences, steps relative to each parameter."""
    columns = []
    for i, value in enumerate(vector):
        step = 1e-5 * abs(value) if model.parameters[i].scale == "log" else 1e-6
        up, down = vector.copy(), vector.copy()
        up[i] += step
        down[i] -= step
        columns.append((model.stiffness(s, up) - model.stiffness(s, down)) / (2 * step))
    return np.stack(columns, axis=-1)


@pytest.mark.parametrize("name", PAPER_MODEL_ORDER)
def test_gradient_equals_finite_differences(name):
    """dZ/dθ through springs, dashpots, spring-pots (incl. d/dα of η s^α), parallel sums and series compliances,
    at s = jω and at s = σ + jω; each column as the sensitivity θ·dZ/dθ relative to |Z|."""
    model = PAPER_MODELS[name]
    rng = np.random.default_rng(sum(map(ord, name)) + 1)
    largest_sensitivity = np.zeros(len(model.parameters))
    for sigma in (0.0, 17.0):
        for _ in range(20):
            vector = model.vector(random_parameters(model, rng))
            s = sigma + 2j * np.pi * rng.uniform(1.0, 5000.0, 40)
            z, gradient = model.stiffness_and_gradient(s, vector)
            assert gradient.shape == (40, len(vector))
            np.testing.assert_array_equal(z, model.stiffness(s, vector))
            z_log, gradient_log = model.stiffness_and_gradient(s, vector, log_laplace(s))  # the fitters' fast path
            np.testing.assert_allclose(z_log, z, rtol=1e-13)
            np.testing.assert_allclose(gradient_log, gradient, rtol=1e-13, atol=1e-13 * np.max(np.abs(gradient)))
            scale = np.where([p.scale == "log" for p in model.parameters], vector, 1.0)
            error = np.abs((gradient - central_differences(model, s, vector)) * scale) / np.abs(z)[:, np.newaxis]
            assert np.max(error) <= 1e-6, (name, sigma, np.max(error, axis=0))
            sensitivity = np.max(np.abs(gradient * scale) / np.abs(z)[:, np.newaxis], axis=0)
            largest_sensitivity = np.maximum(largest_sensitivity, sensitivity)
    assert np.all(largest_sensitivity > 0.1), largest_sensitivity  # every parameter mattered somewhere


def test_gradient_is_vectorised_and_exact_for_a_nested_network():
    model = get_model("(k1 -- (k2 || pot(c, a))) || dashpot(e)")
    p = dict(k1=4e6, k2=1e6, c=3e4, a=0.6, e=2e3)
    s = 5.0 + 2j * np.pi * np.linspace(1.0, 2000.0, 30)
    _, gradient = model.stiffness_and_gradient(s, p)
    inner = p["k2"] + p["c"] * s ** p["a"]
    d_inner = (p["k1"] / (p["k1"] + inner)) ** 2  # d(k1·Y/(k1 + Y))/dY
    expected = {
        "k1": (inner / (p["k1"] + inner)) ** 2,
        "k2": d_inner,
        "c": d_inner * s ** p["a"],
        "a": d_inner * p["c"] * s ** p["a"] * np.log(s),
        "e": s,
    }
    for i, name in enumerate(model.parameter_names):
        assert relative_error(gradient[:, i], expected[name]) <= 1e-12, name
    rng = np.random.default_rng(5)
    sets = np.array([[model.vector(random_parameters(model, rng)) for _ in range(4)] for _ in range(3)])
    together_z, together = model.stiffness_and_gradient(s, sets)
    assert together_z.shape == (3, 4, 30) and together.shape == (3, 4, 30, 5)
    np.testing.assert_array_equal(together[2, 1], model.stiffness_and_gradient(s, sets[2, 1])[1])


@pytest.mark.parametrize("name", PAPER_MODEL_ORDER)
def test_text_form_round_trips(name):
    model = PAPER_MODELS[name]
    again = parse_network(model.text, name)
    assert again.text == model.text
    assert again.parameter_names == model.parameter_names
    rng = np.random.default_rng(11)
    params = random_parameters(model, rng)
    s = 2j * np.pi * np.linspace(1.0, 2000.0, 50)
    np.testing.assert_array_equal(again.stiffness(s, params), model.stiffness(s, params))
    assert get_model(name.lower()) is model


def test_a_user_defined_network():
    model = get_model("k0 || pot(c, a) || (k1 -- dashpot(e)) || (k2 -- (k3 || dashpot(f)))")
    assert model.parameter_names == ("k0", "c", "a", "k1", "e", "k2", "k3", "f")
    p = dict(k0=2e6, c=3e4, a=0.6, k1=5e6, e=4e3, k2=7e6, k3=1e6, f=2e3)
    s = 2j * np.pi * np.linspace(1.0, 2000.0, 50)
    arm = (p["k3"] + p["f"] * s) * p["k2"] / (p["k3"] + p["f"] * s + p["k2"])
    expected = p["k0"] + p["c"] * s ** p["a"] + p["k1"] * p["e"] * s / (p["k1"] + p["e"] * s) + arm
    assert relative_error(model.stiffness(s, p), expected) <= RTOL
    assert parse_network(model.text).text == model.text


@pytest.mark.parametrize(
    "text",
    ["", "k ||", "k -- (dashpot(c)", "pot(c)", "k + c", "k || k"],
)
def test_bad_network_text_is_a_one_line_setting_error(text):
    with pytest.raises(SettingError) as error:
        parse_network(text)
    assert "\n" not in str(error.value)


def test_unknown_model_name_is_a_setting_error():
    with pytest.raises(SettingError, match="unknown"):
        get_model("FOXGF")


@pytest.mark.parametrize("name, arms", [
    ("FOMGF", (("k1", "eta1", "alpha"), ("k2", "eta2", "beta"))),
    ("Maxwell", (("k1", "eta1"), ("k2", "eta2"))),
])
def test_interchangeable_arms_are_named_in_one_order(name, arms):
    """FOMGF's and Maxwell's two arms give the same film either way round; a fit may land on either, and a
    campaign's table then swapped columns between sessions. The canonical order: higher fractional order first,
    then the stiffer spring — the paper's Table 1 is already in it."""
    from gasfilm.analysis.physics.elements import PAPER_TABLE1

    model = get_model(name)
    values = dict(PAPER_TABLE1[name])
    swapped = dict(values)
    for first, second in zip(*arms):
        swapped[first], swapped[second] = values[second], values[first]
    s = 2j * np.pi * np.linspace(20.0, 1000.0, 50)
    assert np.allclose(model.stiffness(s, values), model.stiffness(s, swapped), rtol=1e-12)
    assert model.mapping(model.canonical(model.vector(swapped))) == values
    assert model.mapping(model.canonical(model.vector(values))) == values
    assert np.array_equal(get_model("FOZGF").canonical([1.0, 2.0, 3.0, 0.5]), [1.0, 2.0, 3.0, 0.5])


def test_at_a_fits_resonance_the_arm_that_carries_the_film_comes_first():
    """A spare arm (issue 31: a 0.1 g inertance on 354 N/m, order 1.999) has the higher order, so by orders it
    would come first in some sessions and last in others; at the fit's resonance it carries almost nothing of the
    film, and the arm that carries it is named arm 1 in every session."""
    model = get_model("FOMGF")
    film = {"k": 2.91e6, "eta": 16.14, "order": 1.7472}
    spare = {"k": 354.0, "eta": 1e-4, "order": 1.999}
    values = {"k3": 3.27e7, "k1": spare["k"], "eta1": spare["eta"], "alpha": spare["order"],
              "k2": film["k"], "eta2": film["eta"], "beta": film["order"]}
    by_order = model.mapping(model.canonical(model.vector(values)))
    assert by_order["alpha"] == spare["order"]
    at_resonance = model.mapping(model.canonical(model.vector(values), 2j * np.pi * 199.0))
    assert (at_resonance["k1"], at_resonance["eta1"], at_resonance["alpha"]) == tuple(film.values())
    assert (at_resonance["k2"], at_resonance["eta2"], at_resonance["beta"]) == tuple(spare.values())


def test_a_fit_names_the_arms_in_the_canonical_order():
    from gasfilm.analysis.identification import fit_model
    from gasfilm.analysis.physics.elements import PAPER_MASS_KG, PAPER_TABLE1

    model = get_model("FOMGF")
    values = dict(PAPER_TABLE1["FOMGF"])
    swapped = {**values, "k1": values["k2"], "k2": values["k1"], "eta1": values["eta2"], "eta2": values["eta1"],
               "alpha": values["beta"], "beta": values["alpha"]}
    freq_hz = np.linspace(20.0, 1000.0, 200)
    h = accelerance(model, swapped, freq_hz, PAPER_MASS_KG)
    fit = fit_model(model, freq_hz, h, PAPER_MASS_KG)
    assert fit.params["alpha"] >= fit.params["beta"]
