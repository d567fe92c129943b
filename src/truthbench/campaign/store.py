"""The results store: one HDF5 file per campaign run.

Layout (all SI units; FRFs complex (n_freq, n_out, n_in))::

    /                      attrs: format, truthbench_version, seed, campaign, spec_json,
                                  created_utc, n_trials
    /nominal               attrs: parameter -> value
    /trials/0000           attrs: status ("ok" | "failed"), error
        truth              attrs: parameter -> value
        seconds            attrs: stage -> wall-clock seconds (results.STAGES)
        tests/<name>       datasets freq_hz, H, coherence, u, y (u, y empty for trials
                           whose time histories the campaign's [output] does not keep);
                           attrs fs_hz, input_labels, output_labels
        tests/<name>/parameters   attrs: the exact truth parameters of this test
        tests/<name>/identified   datasets freq_hz, damping_ratio, shapes (pLSCF)
        update             datasets names, initial, values, history, cost_history,
                           singular_values, correlation; attrs converged, method,
                           condition_number
        model/<name>       datasets H_initial, H_updated, update_mask
        updates/<method>   the same for every updater run side by side (or attr error)
        accuracy/initial, accuracy/updated, accuracy/<method>   modes against the truth
                           at the sensors: truth_freq_hz, freq_error_pct,
                           damping_error_pct, mac
        uncertainty        names, theta_0, theta_tests, theta_truth (per test), mean, std,
                           bound (Eq. 10.46-10.50), inside (truth within the bound),
                           holdout (tests that did not build the bound)

A failed trial is written with what it had computed, so nothing is lost.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from truthbench.errors import DataFormatError

FORMAT = "truthbench-results-1"


def _attrs(group, mapping):
    for k, v in mapping.items():
        group.attrs[k] = v


def write_results(result, path: str | Path) -> Path:
    """Write a :class:`~truthbench.campaign.results.CampaignResult` to HDF5."""
    import h5py

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".part")
    with h5py.File(tmp, "w") as f:
        _attrs(f, {
            "format": FORMAT, "truthbench_version": result.version, "seed": result.seed,
            "campaign": result.spec.campaign.name,
            "spec_json": json.dumps(result.spec.to_toml_dict()),
            "source": result.spec.source,
            "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
            "n_trials": len(result.trials)})
        _attrs(f.create_group("nominal"), result.nominal)
        trials = f.create_group("trials")
        for tr in result.trials:
            g = trials.create_group(f"{tr.trial:04d}")
            g.attrs["status"] = "failed" if tr.error else "ok"
            g.attrs["error"] = tr.error or ""
            _attrs(g.create_group("truth"), tr.truth)
            _attrs(g.create_group("seconds"), tr.seconds)
            tests = g.create_group("tests")
            for rec in tr.tests:
                t = tests.create_group(rec.name)
                for name in ("freq_hz", "H", "coherence"):
                    t.create_dataset(name, data=getattr(rec, name))
                for name in ("u", "y"):
                    t.create_dataset(name, data=getattr(rec, name), compression="gzip",
                                     compression_opts=4, shuffle=True)
                _attrs(t, {"fs_hz": rec.fs_hz, "input_labels": list(rec.input_labels),
                           "output_labels": list(rec.output_labels)})
                _attrs(t.create_group("parameters"), rec.parameters)
                _write_modes(t, rec.modes)
            if tr.uncertainty is not None:
                st = g.create_group("uncertainty")
                st.create_dataset("names", data=np.array(tr.uncertainty.names, dtype="S"))
                for name in ("theta_0", "theta_tests", "theta_truth", "mean", "std", "bound",
                             "inside", "mode_index", "holdout", "theta_updated"):
                    if getattr(tr.uncertainty, name) is not None:
                        st.create_dataset(name, data=getattr(tr.uncertainty, name))
            if tr.update is not None:
                _write_update(g.create_group("update"), tr.update)
                for method, res in tr.comparison.items():
                    c = g.create_group(f"updates/{method}")
                    if isinstance(res, str):
                        c.attrs["error"] = res
                    else:
                        _write_update(c, res)
                for stage, acc in tr.accuracy.items():
                    a = g.create_group(f"accuracy/{stage}")
                    for key, value in acc.items():
                        a.create_dataset(key, data=value)
                m = g.create_group("model")
                for rec, hi, hu, mask in zip(tr.tests, tr.H_initial, tr.H_updated,
                                             tr.update_mask, strict=True):
                    mg = m.create_group(rec.name)
                    mg.create_dataset("H_initial", data=hi)
                    mg.create_dataset("H_updated", data=hu)
                    mg.create_dataset("update_mask", data=mask)
    tmp.replace(path)
    return path


def write_test_record(record, path: str | Path, *, spec, seed: int, trial: int,
                      injected=()) -> Path:
    """Write one test (time histories, FRFs, truth record) to HDF5, in the layout of a
    test group of a results file, with the campaign spec and what was injected."""
    import h5py

    from truthbench import __version__

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        _attrs(f, {"format": FORMAT + "/test", "truthbench_version": __version__,
                   "seed": seed, "trial": trial, "campaign": spec.campaign.name,
                   "spec_json": json.dumps(spec.to_toml_dict()), "source": spec.source,
                   "injected": json.dumps(list(injected)),
                   "created_utc": datetime.now(UTC).isoformat(timespec="seconds")})
        t = f.create_group(f"tests/{record.name}")
        for name in ("freq_hz", "H", "coherence"):
            t.create_dataset(name, data=getattr(record, name))
        for name in ("u", "y"):
            t.create_dataset(name, data=getattr(record, name), compression="gzip",
                             compression_opts=4, shuffle=True)
        _attrs(t, {"fs_hz": record.fs_hz, "input_labels": list(record.input_labels),
                   "output_labels": list(record.output_labels)})
        _attrs(t.create_group("parameters"), record.parameters)
        _write_modes(t, record.modes)
    return path


def _write_update(u, res) -> None:
    u.create_dataset("names", data=np.array(res.names, dtype="S"))
    for name in ("initial", "values", "history", "cost_history", "singular_values",
                 "correlation"):
        u.create_dataset(name, data=getattr(res, name))
    _attrs(u, {"converged": res.converged, "method": res.method,
               "condition_number": res.condition_number})


def _write_modes(group, modes) -> None:
    """Identified modes of a test under ``identified/`` (freq_hz, damping_ratio, shapes
    (n_out, n_modes) complex, displacement-equivalent)."""
    if modes is None:
        return
    g = group.create_group("identified")
    g.create_dataset("freq_hz", data=np.asarray(modes.freq_hz))
    g.create_dataset("damping_ratio", data=np.asarray(modes.damping_ratio))
    g.create_dataset("shapes", data=np.asarray(modes.shapes))


def _read_group(g) -> dict:
    out = {"attrs": {k: _plain(v) for k, v in g.attrs.items()}}
    for k, v in g.items():
        out[k] = _read_group(v) if hasattr(v, "keys") else v[()]
    return out


def _plain(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.dtype.kind in "OS":
        return [x.decode() if isinstance(x, bytes) else x for x in v.tolist()]
    if isinstance(v, np.generic):
        return v.item()
    return v


def read_results(path: str | Path) -> dict:
    """Read a results file into nested dicts of arrays and attributes.

    Raises
    ------
    DataFormatError
        If the file is missing, not HDF5, or not a truthbench results file.
    """
    import h5py

    path = Path(path)
    if not path.exists():
        raise DataFormatError(f"{path}: results file not found")
    try:
        with h5py.File(path, "r") as f:
            fmt = f.attrs.get("format")
            if not str(_plain(fmt)).startswith(FORMAT):
                raise DataFormatError(f"{path}: not a truthbench results file (attribute "
                                      f"'format' is {_plain(fmt)!r}; expected {FORMAT!r})")
            data = _read_group(f)
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot be read as HDF5 ({exc})") from None
    data["attrs"]["spec"] = json.loads(data["attrs"]["spec_json"])
    if "trials" not in data and "tests" in data:  # a single-test file from 'simulate'
        data["attrs"]["single_test"] = True
    data["path"] = str(path)
    return data


# ------------------------------------------------------------------------------------
# The FRFData reader of results and 'simulate' files, registered with truthbench.io for
# .h5 and .hdf5 when this module is imported (``import truthbench`` imports it).
# ------------------------------------------------------------------------------------


def _frf_channels(path: Path, test: str, outputs, inputs, coordinates: dict):
    """Channels from stored labels: outputs ``station.direction.qty`` (qty a short label
    of :mod:`truthbench.quantities`), inputs ``station.direction`` (forces)."""
    from truthbench.measure.frfdata import DIRECTIONS, Channel
    from truthbench.quantities import QUANTITIES

    shorts = {q.short: q.name for q in QUANTITIES.values() if q.power is not None}

    def refuse(label, side):
        form = (f"'<station>.<direction>.<qty>' with qty one of {sorted(shorts)}"
                if side == "output" else "'<station>.<direction>'")
        return DataFormatError(f"{path}: test {test!r}: {side} label {label!r} is not of the "
                               f"form {form} and direction one of {list(DIRECTIONS)}")

    outs, ins = [], []
    for label in outputs:
        parts = str(label).rsplit(".", 2)
        if len(parts) != 3 or parts[1] not in DIRECTIONS or parts[2] not in shorts:
            raise refuse(label, "output")
        outs.append(Channel(str(label), shorts[parts[2]], parts[1], station=parts[0],
                            coordinates_m=coordinates.get(parts[0])))
    for label in inputs:
        parts = str(label).rsplit(".", 1)
        if len(parts) != 2 or parts[1] not in DIRECTIONS:
            raise refuse(label, "input")
        ins.append(Channel(str(label), "force", parts[1], station=parts[0],
                           coordinates_m=coordinates.get(parts[0])))
    return tuple(outs), tuple(ins)


def _station_coordinates(spec: dict) -> tuple[dict, str | None]:
    """Station -> (x, 0, 0) m on the nominal beam of a stored spec (as the runner places
    the channels), and a note when the spec does not build a plant (no coordinates)."""
    from truthbench.campaign.spec import parse_campaign

    try:
        parsed = parse_campaign(spec, "stored spec")
        plant = parsed.make_plant()
        x = plant.node_x_m(parsed.nominal_parameters())
    except (ValueError, KeyError, TypeError) as exc:  # an old or partial spec
        return {}, f"no station coordinates: the stored spec does not build a plant ({exc})"
    out = {}
    for station in plant.station_fractions():
        try:
            out[station] = (float(x[plant.station_node(station)]), 0.0, 0.0)
        except ValueError:  # a station between nodes of this mesh: unused by the tests
            continue
    return out, None


def read_frf(path: str | Path, *, trials=None, tests=None) -> tuple:
    """The FRFs of a results file or a 'simulate' file as FRFData (the ``.h5`` reader).

    Parameters
    ----------
    path : str or pathlib.Path
        Written by :func:`write_results` or :func:`write_test_record`.
    trials : int or sequence of int, optional
        Only these trials (default: all).
    tests : str or sequence of str, optional
        Only these tests, by name (default: all).

    Returns
    -------
    tuple of FRFData
        One per (trial, test), named ``"trial <k> / <test>"``: ``H`` (n_freq, n_out, n_in)
        and coherence as stored, channels from the stored labels (quantity, direction,
        station) at the stations' coordinates on the nominal beam of the stored spec
        (x along the beam, m), the test's ``band_hz`` and ``averages`` from the spec.

    Raises
    ------
    DataFormatError
        Missing file, not HDF5, not a truthbench file, a label of unknown form, a trial
        or test that is not in the file, or no stored FRF.
    """
    import h5py

    from truthbench.measure.frfdata import FRFData

    path = Path(path)
    if not path.exists():
        raise DataFormatError(f"{path}: results file not found")
    want_trials = None if trials is None else (
        {int(trials)} if isinstance(trials, int | np.integer) else {int(t) for t in trials})
    want_tests = None if tests is None else (
        {tests} if isinstance(tests, str) else {str(t) for t in tests})
    out = []
    try:
        with h5py.File(path, "r") as f:
            fmt = str(_plain(f.attrs.get("format")))
            if not fmt.startswith(FORMAT):
                raise DataFormatError(f"{path}: not a truthbench results file (attribute "
                                      f"'format' is {fmt!r}; expected {FORMAT!r})")
            spec = json.loads(str(_plain(f.attrs.get("spec_json", "{}"))))
            if "trials" in f:
                groups = [(int(k), f["trials"][k].get("tests", {})) for k in f["trials"]]
            else:  # a single-test file written by 'truthbench simulate'
                groups = [(int(_plain(f.attrs.get("trial", 0))), f.get("tests", {}))]
            found_trials = sorted(t for t, _ in groups)
            found_tests = sorted({name for _, g in groups for name in g})
            if want_trials is not None and want_trials - set(found_trials):
                raise DataFormatError(f"{path}: no trial {sorted(want_trials - set(found_trials))}"
                                      f" in the file; it holds trials {found_trials}")
            if want_tests is not None and want_tests - set(found_tests):
                raise DataFormatError(f"{path}: no test {sorted(want_tests - set(found_tests))} "
                                      f"in the file; it holds tests {found_tests}")
            by_test = {t.get("name"): t for t in spec.get("tests", [])
                       if isinstance(t, dict)}
            coordinates, note = _station_coordinates(spec)
            for trial, tests_group in groups:
                if want_trials is not None and trial not in want_trials:
                    continue
                for name, t in tests_group.items():
                    if want_tests is not None and name not in want_tests:
                        continue
                    if "H" not in t or "freq_hz" not in t:
                        continue
                    H = t["H"][()]
                    outputs = _plain(t.attrs.get("output_labels", []))
                    inputs = _plain(t.attrs.get("input_labels", []))
                    outs, ins = _frf_channels(path, name, outputs, inputs, coordinates)
                    coherence = t["coherence"][()] if "coherence" in t else None
                    if coherence is not None and coherence.shape != H.shape:
                        coherence = None
                    test_spec = by_test.get(name, {})
                    band = test_spec.get("band_hz")
                    notes = [f"H1 as stored by the campaign runner (fs "
                             f"{_plain(t.attrs.get('fs_hz'))} Hz) in {path.name}"]
                    if note and not coordinates:
                        notes.append(note)
                    out.append(FRFData(
                        name=f"trial {trial} / {name}", freq_hz=t["freq_hz"][()], H=H,
                        outputs=outs, inputs=ins, coherence=coherence,
                        n_averages=test_spec.get("averages"),
                        band_hz=None if band is None else (float(band[0]), float(band[1])),
                        notes=tuple(notes)))
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot be read as HDF5 ({exc})") from None
    if not out:
        raise DataFormatError(
            f"{path}: the file holds no test with stored FRFs (trials/*/tests/*/H or "
            f"tests/*/H, and freq_hz); expected at least one")
    return tuple(out)


def _register_frf_reader() -> None:
    from truthbench.io import register_reader

    for ext in (".h5", ".hdf5"):
        register_reader(ext, read_frf)


_register_frf_reader()
