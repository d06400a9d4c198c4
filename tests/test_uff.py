"""UFF 58 via pyuff: FRF/coherence export round trip, import of time records, errors naming the file."""

from __future__ import annotations

import numpy as np
import pytest
import pyuff

from gasfilm.analysis.session import Session
from gasfilm.analysis.spectra import WindowSettings, compute_frf
from gasfilm.analysis.uff import UffError, export_frf_uff, import_uff_session, read_uff_time_records
from gasfilm.analysis.validation import ValidationSettings
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2
from test_session import RATE_HZ, synthetic_hits


def time_record(values, node, direction, data_type, units, ref=(1, 3), hit=0, binary=0, sample_rate_hz=RATE_HZ):
    """One dataset 58 time record as a UFF writer of another program would produce it."""
    return pyuff.prepare_58(
        binary=binary,
        id1=f"hit {hit}",
        func_type=1,
        ver_num=hit,
        rsp_node=node,
        rsp_dir=direction,
        ref_node=ref[0],
        ref_dir=ref[1],
        abscissa_spacing=1,
        abscissa_spec_data_type=17,
        abscissa_axis_units_lab="s",
        ordinate_spec_data_type=data_type,
        ordinate_axis_units_lab=units,
        orddenom_spec_data_type=0,
        data=np.asarray(values, dtype=float),
        x=np.arange(len(values)) / sample_rate_hz,
    )


def write_uff(path, datasets):
    pyuff.UFF(str(path)).write_sets(datasets, mode="overwrite")
    return path


def test_frf_and_coherence_export_round_trip(tmp_path):
    hits = synthetic_hits(4)
    frf = compute_frf(np.stack([hit.data for hit in hits]), RATE_HZ, WindowSettings(exponential_end_fraction=0.2))
    path = export_frf_uff(frf, tmp_path / "frf.uff", response_dof=(7, 3), reference_dof=(2, -3))
    sets = pyuff.UFF(str(path)).read_sets()
    assert [s["type"] for s in sets] == [164, 58, 58]
    assert sets[0]["units_code"] == 1
    h1_set, coherence_set = sets[1], sets[2]
    assert (h1_set["func_type"], coherence_set["func_type"]) == (4, 6)
    assert (h1_set["ordinate_spec_data_type"], h1_set["orddenom_spec_data_type"]) == (12, 13)
    assert (h1_set["ordinate_axis_units_lab"], h1_set["orddenom_axis_units_lab"]) == ("m/s^2", "N")
    assert (h1_set["rsp_node"], h1_set["rsp_dir"], h1_set["ref_node"], h1_set["ref_dir"]) == (7, 3, 2, -3)
    np.testing.assert_allclose(h1_set["x"], frf.freq_hz, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(h1_set["data"], frf.h1, rtol=1e-11, atol=0)
    np.testing.assert_allclose(coherence_set["data"], frf.coherence, rtol=1e-11, atol=0)
    assert np.iscomplexobj(h1_set["data"]) and not np.iscomplexobj(coherence_set["data"])


def test_import_time_records_by_data_type_and_units(tmp_path):
    hits = synthetic_hits(3, seed=5)
    datasets = []
    for hit in hits:
        # hit 1 comes in lbf and g, the others in SI; response first for hit 2 (order inside a hit is free)
        force, response = hit.data
        force_record = (time_record(force / 4.4482216152605, 1, 3, 13, "lbf", hit=hit.index) if hit.index == 1
                        else time_record(force, 1, 3, 13, "N", hit=hit.index))
        response_record = (time_record(response / STANDARD_GRAVITY_M_S2, 5, 3, 12, "g", hit=hit.index)
                           if hit.index == 1 else time_record(response, 5, 3, 12, "m/s^2", hit=hit.index, binary=1))
        datasets += [response_record, force_record] if hit.index == 2 else [force_record, response_record]
    path = write_uff(tmp_path / "hits.uff", datasets)
    records = read_uff_time_records(path)
    assert records.sample_rate_hz == RATE_HZ  # snapped from the 5-digit abscissa increment
    assert (records.force_dof, records.response_dof) == ((1, 3), (5, 3))
    np.testing.assert_allclose(records.records, np.stack([hit.data for hit in hits]), rtol=1e-10, atol=1e-12)

    session_path = import_uff_session(path, tmp_path / "hits.h5", ValidationSettings())
    with Session.open(session_path) as session:
        assert session.hit_count == 3 and session.sample_rate_hz == RATE_HZ
        assert all(verdict.accepted for verdict in session.verdicts())  # UFF carries no overload flags
        np.testing.assert_allclose(session.accepted_records(), records.records, rtol=0, atol=0)
        assert session.settings["source"]["response_dof"] == [5, 3]


def test_import_maps_untyped_records_by_node_and_direction(tmp_path):
    hits = synthetic_hits(2, seed=2)
    datasets = []
    for hit in hits:
        force, response = hit.data
        datasets += [
            time_record(response, 4, 2, 0, "NONE", ref=(1, 3), hit=hit.index),  # another response DOF
            time_record(force, 1, 3, 0, "NONE", ref=(1, 3), hit=hit.index),  # measured at its reference: force
            time_record(response, 5, 3, 0, "NONE", ref=(1, 3), hit=hit.index),
        ]
    path = write_uff(tmp_path / "untyped.uff", datasets)
    with pytest.raises(UffError, match=r"response time records at several DOFs \(node 4 dir 2, node 5 dir 3\)"):
        read_uff_time_records(path)
    records = read_uff_time_records(path, response_dof=(5, 3))
    assert (records.force_dof, records.response_dof) == ((1, 3), (5, 3))
    np.testing.assert_allclose(records.records, np.stack([hit.data for hit in hits]), rtol=1e-10, atol=1e-12)
    with pytest.raises(UffError, match="no response time record at node 9 dir 1"):
        read_uff_time_records(path, response_dof=(9, 1))


def test_uff_errors_name_the_file(tmp_path):
    empty = tmp_path / "empty.uff"
    empty.write_bytes(b"")
    with pytest.raises(UffError, match=f"{empty}: empty UFF file"):
        read_uff_time_records(empty)
    with pytest.raises(UffError, match="no such UFF file"):
        read_uff_time_records(tmp_path / "missing.uff")

    hits = synthetic_hits(2)
    frf = compute_frf(np.stack([hit.data for hit in hits]), RATE_HZ)
    only_frf = export_frf_uff(frf, tmp_path / "frf.uff")
    with pytest.raises(UffError, match=r"holds an FRF but no time records \(dataset 58 with function type 1\)"):
        read_uff_time_records(only_frf)

    force, response = hits[0].data
    uneven = write_uff(tmp_path / "uneven.uff", [time_record(force, 1, 3, 13, "N"),
                                                 time_record(response[:-10], 5, 3, 12, "m/s^2")])
    with pytest.raises(UffError, match="inconsistent lengths \\(2550, 2560 samples\\): hit 1's force \\(dataset 1\\) "
                                      "and response \\(dataset 2\\)"):
        read_uff_time_records(uneven)

    unpaired = write_uff(tmp_path / "unpaired.uff", [time_record(force, 1, 3, 13, "N"),
                                                     time_record(force, 1, 3, 13, "N", hit=1),
                                                     time_record(response, 5, 3, 12, "m/s^2")])
    with pytest.raises(UffError, match="2 force records but 1 response records"):
        read_uff_time_records(unpaired)

    marked = response.copy()
    marked[50] = 123456.789  # pyuff writes NaN as 0, so the NaN is put into the text the way other writers do
    nan_file = write_uff(tmp_path / "nan.uff", [time_record(force, 1, 3, 13, "N"),
                                                time_record(marked, 5, 3, 12, "m/s^2")])
    text = nan_file.read_text()
    assert text.count("1.23456789000e+05") == 1
    nan_file.write_text(text.replace("1.23456789000e+05", "NaN".rjust(17)))
    with pytest.raises(UffError, match=r"nan.uff: dataset 2 \(response time record of hit 1\) has NaN samples"):
        read_uff_time_records(nan_file)

    odd_units = write_uff(tmp_path / "units.uff", [time_record(force, 1, 3, 13, "N"),
                                                   time_record(response, 5, 3, 12, "in/s^2")])
    with pytest.raises(UffError, match="units 'in/s\\^2', which gasfilm cannot convert"):
        read_uff_time_records(odd_units)


def test_an_imported_real_recording_replays_with_all_five_hits_accepted(tmp_path, capsys):
    """pyFRF's 5 real hits (25.6 kS/s, peaks beyond the PCB sensors' ±5 V ranges gasfilm would assume) brought in as
    UFF time records: the import knows units, not input ranges, so no hit is called an overload; the ringing tail asks
    for the exponential window the decay check names, and with it all 5 hits are accepted, at import and on replay."""
    import json

    from gasfilm.app.cli import main as gasfilm
    from gasfilm.drivers.interface import default_hammer_and_accelerometer
    from test_real_data import FIXTURE, FS_HZ

    measured = np.stack([np.load(FIXTURE / f"measurements_{i}.npy") for i in range(1, 6)])[:, 1:]
    placeholder = default_hammer_and_accelerometer(FS_HZ).channels
    assert np.sum(np.max(np.abs(measured[:, 1]), axis=1) >= 0.98 * placeholder[1].full_scale_si) >= 4
    datasets = []
    for index, (force, response) in enumerate(measured):
        datasets += [time_record(force, 1, 3, 13, "N", hit=index, sample_rate_hz=FS_HZ),
                     time_record(response, 2, 3, 12, "m/s^2", hit=index, sample_rate_hz=FS_HZ)]
    uff_path = write_uff(tmp_path / "pyfrf.uff", datasets)
    window = WindowSettings(exponential_end_fraction=0.01)
    session_path = import_uff_session(uff_path, tmp_path / "pyfrf.h5", ValidationSettings(), window)
    with Session.open(session_path) as session:
        assert [v.accepted for v in session.verdicts()] == [True] * 5
        assert session.settings["source"]["full_scale_known"] is False

    assert gasfilm(["replay", str(session_path), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["hits"], summary["accepted"], summary["reasons"]) == (5, 5, {})
    # without the window the hits are truncated: a recording from elsewhere keeps them, flagged, never "overload"
    assert gasfilm(["replay", str(session_path), "--rectangular"]) == 0
    text = capsys.readouterr().out
    assert "accepted but flagged (response not decayed): 5" in text and "overload" not in text
    assert "--exp-end" in text and "leakage" in text


def test_hits_of_different_lengths_are_cut_to_the_shortest_and_said_so(tmp_path):
    """Red team round 8: a recorder that changed its record length mid-session (1 s, then 0.5 s records) is normal
    input, not an error: every record is cut to the shortest from its start, and a note says which hits lost samples.
    A hit whose own force and response records differ in length stays refused (a damaged pairing)."""
    hits = synthetic_hits(4)
    datasets = []
    for hit, record in enumerate(hits):
        force, response = record.data if hit < 2 else record.data[:, :2000]
        datasets += [time_record(force, 1, 3, 13, "N", hit=hit), time_record(response, 5, 3, 12, "m/s^2", hit=hit)]
    read = read_uff_time_records(write_uff(tmp_path / "mixed.uff", datasets))
    assert read.records.shape == (4, 2, 2000)
    np.testing.assert_allclose(read.records[0], hits[0].data[:, :2000], rtol=1e-10)  # ASCII UFF: 12 digits
    assert "different lengths (2000, 2560 samples)" in read.length_note and "hits 1, 2 lose" in read.length_note
    assert read_uff_time_records(write_uff(tmp_path / "even.uff", datasets[4:])).length_note is None
