"""The mover as a rigid body (issue 34): the rig spec's [rigid_body], the simulator's accelerometers, the rigid-body
FRFs, identification per direction with the couplings, the CLI's roving test, and the one-accelerometer path as it
was, bit for bit."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from gasfilm.analysis.capture import HitRecord
from gasfilm.analysis.identification.rigid import identify_rigid
from gasfilm.analysis.physics import rigid_body
from gasfilm.analysis.physics.elements import accelerance, get_model
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.physics.response import rig_accelerance
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_frf import rigid_frf
from gasfilm.analysis.rigid_session import rigid_daq_config
from gasfilm.analysis.spectra import WindowSettings, compute_frf
from gasfilm.analysis.validation import OVERLOAD, validate_hit
from gasfilm.app.cli import main as gasfilm
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.plant import MultiResponsePlant
from gasfilm.drivers.simulated import SimulatedNI9234

ROOT = Path(__file__).resolve().parents[1]
RIGS = ROOT / "fixtures" / "rigs"
RATE_HZ = 6400.0
#: What the proof asks of the identified stiffness and damping (issue 34).
TOLERANCE = 0.02


def three_pads(offset: bool = False) -> RigSpec:
    """The fixture's mover on three equal pads; ``offset``: pad 1 stiffer, the elastic centre 14 mm off in x."""
    spec = RigSpec.load(RIGS / "three-pads.toml")
    if not offset:
        return spec
    return spec.with_values(film_parameters={**spec.film_parameters, "k_pad1": 1.4e7, "eta_pad1": 2000.0})


def roving_records(spec: RigSpec, hits: int, points=None, seed: int = 1) -> dict[str, np.ndarray]:
    plant = RigPlant(spec)
    device = SimulatedNI9234(plant, seed=seed, hit_interval_s=None)
    device.configure(rigid_daq_config(spec, RATE_HZ))
    device.start()
    records = {}
    for point in points or spec.rigid_body.point_names:
        plant.strike_at(point)
        records[point] = device.sim_record_hits(hits, int(0.5 * RATE_HZ))
    return records


def test_a_rigid_spec_round_trips_through_toml():
    for name in ("three-pads.toml", "four-pads.toml"):
        spec = RigSpec.load(RIGS / name)
        again = RigSpec.from_toml(spec.to_toml())
        assert again == spec and again.to_toml() == spec.to_toml()
        assert spec.film_model.count("||") == 2 * len(spec.rigid_body.pads) - 1  # the pads' parallel network


BASE = (RIGS / "three-pads.toml").read_text()


@pytest.mark.parametrize("change, named", [
    (lambda t: t.replace("inertia_kg_m2 = [0.19, 0.21]", "inertia_kg_m2 = [0.19]"), "rigid_body.inertia_kg_m2"),
    (lambda t: t.replace("[-0.06, 0.10392304845413264]", "[0.0, 0.0]").replace(
        "[-0.06, -0.10392304845413264]", "[-0.12, 0.0]"), "three pads not in line"),
    (lambda t: t.replace('hammer_point = "centre"', 'hammer_point = "middle"'), "rigid_body.hammer_point"),
    (lambda t: t.replace('mass_kg = 25.05', 'mass_kg = 25.05\n[film]\nmodel = "SD"'), "[film]"),
    (lambda t: t.replace("parameters = { k = 1.0e7, eta = 1500.0 }", "parameters = { k = 1.0e7 }", 1),
     "parameters.eta"),
    (lambda t: t.replace('serial = "LW210001"', 'serial = "LW210001"\ntilt = 1'), "unknown key 'tilt'"),
    (lambda t: t + '\n[[effects]]\ntype = "cubic-stiffness"\nk3_n_per_m3 = 1e12\n', "cubic-stiffness"),
])
def test_a_bad_rigid_spec_is_refused_in_one_line_naming_the_key(change, named):
    with pytest.raises(SettingError) as refused:
        RigSpec.from_toml(change(BASE), "rigs/bad.toml")
    message = str(refused.value)
    assert "\n" not in message and message.startswith("rigs/bad.toml") and named in message


def test_one_accelerometer_at_the_centre_of_an_uncoupled_mover_sees_the_heave_film():
    spec = three_pads()
    centred = dataclasses.replace(spec, rigid_body=dataclasses.replace(
        spec.rigid_body, accelerometers=(rigid_body.Accelerometer("centre", (0.0, 0.0)),)))
    freq_hz = np.linspace(5.0, 1500.0, 300)
    expected = accelerance(get_model("SD"), {"k": 3e7, "eta": 4500.0}, freq_hz, 25.05, 20.0)
    np.testing.assert_allclose(rig_accelerance(centred, freq_hz, 20.0), expected, rtol=1e-12)


def test_the_layout_implies_n_k_r2_over_2_for_a_ring_of_pads():
    films = rigid_body.layout_direction_films(three_pads())
    for direction in ("roll", "pitch"):  # K_θ = n·k_pad·r²/2 (issue 34)
        assert films[direction][1]["k"] == pytest.approx(3 * 1e7 * 0.12**2 / 2, rel=1e-12)


def test_the_simulated_accelerometers_read_the_rigid_body_at_their_points():
    """One noise-free hit in a 5 s stream (every tail of the module's chain inside it): each accelerometer's
    spectrum over the force's is the rigid body's accelerance at its point for the struck point."""
    spec = three_pads(offset=True)
    plant = RigPlant(spec)
    assert isinstance(plant, MultiResponsePlant) and plant.response_count == 3
    device = SimulatedNI9234(plant, seed=2, hit_interval_s=None, noise=False, quantize=False)
    device.configure(rigid_daq_config(spec, RATE_HZ))
    device.start()
    plant.strike_at("north-east")
    device.read(np.empty((4, int(0.5 * RATE_HZ))))
    device.sim_hit()
    stream = np.empty((4, int(5 * RATE_HZ)))
    device.read(stream)
    freq_hz = np.fft.rfftfreq(stream.shape[1], 1 / RATE_HZ)
    spectra = np.fft.rfft(stream)
    band = (freq_hz >= 20.0) & (freq_hz <= 0.45 * RATE_HZ) & (np.abs(spectra[0]) > 1e-3 * np.abs(spectra[0]).max())
    spectra = spectra[:, band]  # (off the hammer pulse's spectral nulls)
    expected = rigid_body.sensor_accelerances(spec, 2j * np.pi * freq_hz[band], "north-east")
    # (1e-5 of the peak: a hit is synthesised periodically over the time its response takes to decay)
    np.testing.assert_allclose(spectra[1:] / spectra[0], expected, rtol=1e-6, atol=1e-5 * np.abs(expected).max())


def test_a_roving_hammer_identifies_heave_roll_pitch_within_2_percent_and_finds_the_coupling():
    spec = three_pads(offset=True)
    rigid = rigid_frf(spec, roving_records(spec, 4), RATE_HZ, WindowSettings(), 0, [1, 2, 3])
    assert rigid.full and np.median(rigid.reciprocity_error[rigid.readable()]) < 0.01
    result = identify_rigid(rigid)
    implied = rigid_body.layout_direction_films(spec)
    for direction in rigid_body.DIRECTIONS:
        fit = result.directions[direction].fit("SD")
        for name in ("k", "eta"):
            assert fit.params[name] == pytest.approx(implied[direction][1][name], rel=TOLERANCE), (direction, name)
    couplings = rigid_body.layout_coupling_sd(spec)
    heave_pitch = result.term("heave", "pitch")
    assert heave_pitch.found and heave_pitch.stiffness == pytest.approx(couplings[("heave", "pitch")][0],
                                                                         rel=TOLERANCE)
    assert not result.term("heave", "roll").found and result.coupling_found()
    dx, sx, dy, _ = result.elastic_centre_offset_m
    assert dx == pytest.approx((1.4e7 * 0.12 - 2 * 1e7 * 0.06) / 3.4e7, abs=5e-4) and abs(dy) < 5e-4


@pytest.mark.parametrize("offset", [False, True])
def test_a_hammer_at_the_centre_sees_coupling_only_when_the_elastic_centre_is_off(offset):
    spec = three_pads(offset)
    rigid = rigid_frf(spec, roving_records(spec, 4, ["centre"]), RATE_HZ, WindowSettings(), 0, [1, 2, 3])
    result = identify_rigid(rigid)
    assert list(result.directions) == ["heave"] and not rigid.full
    assert result.coupling_found() is offset
    if not offset:  # an uncoupled film: heave from the centre alone
        assert result.directions["heave"].fit("SD").params["k"] == pytest.approx(3e7, rel=TOLERANCE)


def test_every_accelerometer_is_checked_for_overload():
    data = np.zeros((4, 1000))
    data[0, 100:111] = 200.0 * np.sin(np.pi * np.arange(11) / 10)
    data[1:, 100:] = np.sin(np.arange(900) / 5.0) * np.exp(-np.arange(900) / 100.0)
    data[3, 300:] = 0.0
    data[3, 200:260] = 480.0  # the third accelerometer clipped at its full scale
    hit = HitRecord(0, data, 6400.0, 100, 0.0, np.zeros(4, bool), 0, 1)
    assert validate_hit(hit, full_scale_si=(446.0, 490.0, 490.0, 490.0)).accepted
    verdict = validate_hit(hit, full_scale_si=(446.0, 490.0, 490.0, 490.0), other_responses=(2, 3))
    assert not verdict.accepted and OVERLOAD in verdict.reasons


def test_the_cli_records_a_roving_test_fits_it_and_exports_it(tmp_path, capsys):
    rig = tmp_path / "rig.toml"
    three_pads(offset=True).save(rig)
    session = tmp_path / "s.h5"
    for run, point in enumerate(("centre", "east", "north")):
        argv = ["acquire", "--rig", str(rig), "--out", str(session), "--hits", "2", "--pacing", "fast",
                "--hit-interval", "0.6", "0.7", "--record-s", "0.5", "--rate", str(RATE_HZ), "--hammer-point", point]
        assert gasfilm(argv[:1] + ["--append"] * bool(run) + argv[1:]) == 0
    printed = capsys.readouterr().out
    assert "hammer point north (struck so far: centre, east, north; next: north-east" in printed
    assert gasfilm(["rigid", str(session), "--json"]) == 0
    stored = json.loads(capsys.readouterr().out)
    assert stored["coupling_found"] and set(stored["directions"]) == {"heave", "roll", "pitch"}
    assert all(Path(figure).is_file() for figure in stored["figures"]) and len(stored["figures"]) == 2
    from gasfilm.analysis.session import Session

    with Session.open(session) as opened:
        assert opened.read_rigid_body()["coupling_found"]
        assert len(opened.daq_config.channels) == 4 and opened.daq_config.channels[1].name == "A1 (s/n LW210001)"
        assert list(opened.frf_hit_indices()) == [0, 1]  # the session's FRF: its spec's point (the centre)
    assert gasfilm(["model", str(session), "--rigid", "--out", str(tmp_path / "plant.npz"), "--json"]) == 0
    plant = json.loads(capsys.readouterr().out)["model"]
    assert plant["stable"] and plant["max_error_band"] < 0.005 and plant["measured_error_median_max"][0] < 0.02
    assert set(plant["couplings_used"]) >= {"heave–pitch"}
    with np.load(tmp_path / "plant.npz") as arrays:
        assert arrays["B"].shape[1] == arrays["C"].shape[0] == 3  # F_z, M_x, M_y → heave, roll, pitch
        np.testing.assert_allclose(arrays["D"], np.linalg.inv(arrays["M"]))
    from gasfilm.analysis.campaign.rigid import direction_column
    from gasfilm.analysis.campaign.session_task import CampaignOptions, analyse_session

    row = analyse_session(str(session), CampaignOptions(models=("SD",), diagnose=False))
    assert row["error"] is None and row["rigid.coupling_found"] and row["rigid.full_matrix"]
    assert row[direction_column("roll", "k")] == pytest.approx(216000.0, rel=TOLERANCE)
    uff = tmp_path / "s.uff"
    assert gasfilm(["export", str(session), "--uff", str(uff)]) == 0
    assert gasfilm(["rigid", str(uff), "--rig", str(rig), "--json", "--no-figures"]) == 0
    again = json.loads(capsys.readouterr().out.splitlines()[-1])
    # the same terms, to a millionth of their standard errors (seen: 1e-8 of them; a coupling near zero, a few N/rad
    # against ±350, moves by more than a millionth of itself with the UFF's rounding)
    for a, b in zip(stored["matrix_terms"], again["matrix_terms"]):
        assert a["stiffness"] == pytest.approx(b["stiffness"], rel=1e-6, abs=1e-6 * a["stiffness_std"])


def test_the_one_accelerometer_path_is_what_it_was_to_rounding():
    sys.path.insert(0, str(ROOT / "tests" / "golden"))
    try:
        import one_accelerometer
    finally:
        sys.path.pop(0)
    before = np.load(ROOT / "tests" / "golden" / "one-accelerometer.npz")
    now = one_accelerometer.figures()
    assert sorted(now) == sorted(before.files)
    for key in before.files:
        if "-fit-" in key:  # (a fit's arithmetic goes through BLAS, whose kernels differ between CPUs in last bits)
            np.testing.assert_allclose(now[key], before[key], rtol=1e-9, err_msg=key)
        else:  # bit for bit on the CPU that stored it; elsewhere vectorised kernels round the last bits differently
            scale = float(np.max(np.abs(before[key]))) if before[key].size else 0.0
            np.testing.assert_allclose(now[key], before[key], rtol=0, atol=1e-12 * scale, err_msg=key)


@pytest.mark.parametrize("described", [True, False])
def test_a_rigid_spec_describes_the_tilt_modes_one_accelerometer_sees(described):
    """Hit off the centre, the first accelerometer sees heave, roll and pitch: the spec with the rigid body
    describes them (consistent); a one-direction spec of the same heave film leaves them unexplained."""
    from gasfilm.analysis.diagnosis import diagnose
    from gasfilm.analysis.diagnosis.recordings import Recordings
    from gasfilm.analysis.diagnosis.parallel import worker_processes

    spec = rigid_body.struck_at(three_pads(), "north-east")
    records = roving_records(spec, 4, ["north-east"])["north-east"][:, :2]
    recordings = Recordings(records, RATE_HZ, np.arange(4) * 2.0, None, None, None, "simulated rigid body")
    given = spec if described else RigSpec.nominal("SD", parameters={"k": 3e7, "eta": 4500.0})
    with worker_processes(1):
        diagnosis = diagnose(recordings, given)
    assert (diagnosis.verdict == "consistent") is described, diagnosis.verdict


def test_films_per_direction_about_the_elastic_centre_are_the_pads_they_describe():
    """Pads whose films are proportional (one stiffer pad) have an elastic centre off the centre of mass; the same
    rig as a heave, a roll and a pitch film about that centre has the same 3×3 film stiffness."""
    pads = three_pads().with_values(film_parameters={**three_pads().film_parameters, "k_pad1": 1.4e7,
                                                     "eta_pad1": 2100.0})
    positions = np.array([pad.position_m for pad in pads.rigid_body.pads])
    k = np.array([1.4e7, 1e7, 1e7])
    total = float(k.sum())
    x_e, y_e = (float(v) for v in k @ positions / total)
    roll, pitch = float(k @ (positions[:, 1] - y_e) ** 2), float(k @ (positions[:, 0] - x_e) ** 2)
    ratio = 1500.0 / 1e7  # the films' damping over stiffness
    body = BASE.split("[[rigid_body.pads]]")[0].replace('mass_kg = 25.05', f'''mass_kg = 25.05
[film]
model = "SD"
parameters = {{ k = {total!r}, eta = {ratio * total!r} }}''')
    body += f'''elastic_centre_m = [{x_e!r}, {y_e!r}]
roll = {{ model = "SD", parameters = {{ k = {roll!r}, eta = {ratio * roll!r} }} }}
pitch = {{ model = "SD", parameters = {{ k = {pitch!r}, eta = {ratio * pitch!r} }} }}
''' + "[[rigid_body.accelerometers]]" + BASE.split("[[rigid_body.accelerometers]]", 1)[1]
    films = RigSpec.from_toml(body, "directions.toml")
    assert RigSpec.from_toml(films.to_toml()) == films
    s = 2j * np.pi * np.array([1.0, 150.0, 900.0])
    np.testing.assert_allclose(rigid_body.film_matrix(films, s), rigid_body.film_matrix(pads, s), rtol=1e-12,
                               atol=1e-6 * 3.4e7)


def test_a_fourth_accelerometer_checks_that_the_mover_is_rigid():
    """Four accelerometers for three motions: the least-squares residual is nothing for a rigid body, and shows an
    accelerometer that reads 5 % more than its place on the body says (a bent mover, a wrong sensitivity)."""
    spec = three_pads()
    body = dataclasses.replace(spec.rigid_body, accelerometers=(
        *spec.rigid_body.accelerometers, rigid_body.Accelerometer("A4", (0.05, -0.05))))
    spec = dataclasses.replace(spec, rigid_body=body)
    n = int(0.5 * RATE_HZ)
    freq_hz = np.fft.rfftfreq(n, 1 / RATE_HZ)
    s = 2j * np.pi * np.maximum(freq_hz, 1e-3)
    force = np.zeros(n)
    force[5:10] = 100.0 * np.sin(np.pi * np.arange(1, 6) / 6)
    records = {}
    for point in ("centre", "east", "north"):
        responses = np.fft.irfft(np.fft.rfft(force) * rigid_body.sensor_accelerances(spec, s, point), n)
        records[point] = np.concatenate([force[np.newaxis], responses])[np.newaxis]
    rigid = rigid_frf(spec, records, RATE_HZ, WindowSettings(), 0, [1, 2, 3, 4])
    band = (freq_hz > 20) & (freq_hz < 1000)
    assert np.max(rigid.rigidity_error[:, band]) < 1e-9
    for point in records:
        records[point][:, 4] *= 1.05
    bent = rigid_frf(spec, records, RATE_HZ, WindowSettings(), 0, [1, 2, 3, 4])
    assert np.median(bent.rigidity_error[:, band]) > 0.005
