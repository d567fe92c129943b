"""The results store: one HDF5 file per campaign run, and reading it back.

:func:`write_results` writes a :class:`~truthbench.campaign.results.CampaignResult`;
:func:`load_results` (``CampaignResult.load``) rebuilds it, typed, from the file;
:func:`read_results` returns the file as nested dicts (for tools that want the raw
layout). :func:`write_test_record` writes the single-test file of
``truthbench simulate``, which :func:`load_results` reads too.

Layout (SI units; FRFs complex (n_freq, n_out, n_in); strings UTF-8)::

    /                      attrs: format, truthbench_version, seed, campaign, spec_json,
                                  source, created_utc, n_trials
    /nominal               attrs: parameter -> value (unit in the name: E_pa, rho_kg_m3)
    /trials/0000           attrs: status ("ok" | "failed"), error
        truth              attrs: parameter -> value
        seconds            attrs: stage -> wall-clock seconds, s (results.STAGES)
        tests/<name>       datasets freq_hz, H, coherence, u, y (u, y have 0 samples for
                           trials whose time histories the campaign's [output] does not
                           keep); attrs fs_hz, input_labels, output_labels;
                           H attrs: n_averages, band_hz, excitation, window_decay_rad_s,
                           notes (the FRFData's)
        tests/<name>/channels/outputs, .../inputs
                           one entry per row / column of H: datasets label, quantity,
                           direction, station, unit (strings, "" for none), sign,
                           point (-1 for none), coordinates_m (n, 3; NaN for none)
        tests/<name>/parameters   attrs: the exact truth parameters of this test
        tests/<name>/identified   datasets freq_hz, damping_ratio, shapes (n_out, n_modes),
                           participation (n_modes, n_in); attr output_labels (pLSCF)
        update             datasets names, initial, values, history, cost_history,
                           singular_values, correlation; attrs converged, method,
                           condition_number
        model/<name>       datasets H_initial, H_updated (lines above 0 Hz), update_mask
        updates/<method>   the same as update for every updater run side by side (or
                           attr error)
        accuracy/initial, accuracy/updated, accuracy/<method>   modes against the truth
                           at the sensors: truth_freq_hz, freq_error_pct,
                           damping_error_pct, mac, n_unpaired_truth
        uncertainty        names, theta_0, theta_tests, theta_truth (per test), mean, std,
                           bound (Eq. 10.46-10.50), inside (truth within the bound),
                           mode_index, holdout (tests that did not build the bound),
                           theta_updated
        frf_band           the FRF-domain band (campaign.frf_band_stage): datasets tests,
                           freq_hz, mean, cov (n_freq, n_out, n_in, 2, 2), line_mask;
                           attrs k_sigma, n_tests, output_labels, input_labels,
                           inside_initial, inside_updated (fractions in [0, 1])

Units: every numeric dataset carries a ``unit`` attribute: ``"Hz"``, ``"s"``, ``"m"``,
``"%"``, ``"-"`` (dimensionless: ratios, MAC, coherence, masks, counts, indices), the
FRF unit from the channels (output unit per input unit: ``"m/s^2/N"``,
``"rad/s/(N m)"``), an update parameter's unit (``"Pa"``, ``"kg/m^3"``). When the
entries of one dataset differ, ``unit`` is an array of strings: per channel pair
(shape (n_out, n_in)) for FRFs, per channel (one per row) for ``u`` and ``y``, per
parameter (one per ``names`` entry) for parameter vectors and tables. The cost of an
update is ``"(weighted residual)^2"`` and its singular values ``"weighted residual per
parameter unit"``: their units depend on the weighting. Identified ``shapes`` and
``participation`` are ``"arb."``: their product is the displacement-equivalent residue,
the split of its scale between them is arbitrary. Attributes holding numbers have their
unit in their name (``fs_hz``, ``E_pa``) or in this docstring.

A run streams its trials to a :class:`TrialStore` first: ``<folder>/trials/run.json``
(the run's identity: format ``truthbench-store-1``, campaign spec, seed, trial count,
version) and ``<folder>/trials/<NNNNNN>.h5``, one file per finished trial in the layout
above (``n_trials`` = 1), written atomically (``.part``, fsync, rename); gathered into
``results.h5`` (attribute ``n_trials_requested`` added) when every trial is stored.
:func:`load_results` reads a run's folder too: its ``results.h5``, else the trials its
store holds.

A failed trial is written with what it had computed, so nothing is lost. Files written
before channels, FRF metadata and units were stored load too: channels are rebuilt
from the stored spec (without coordinates), the FRF metadata from the spec's tests.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from truthbench.errors import DataFormatError, TruthbenchError
from truthbench.io import load_frf, register_reader  # noqa: F401  (load_frf: public, with .h5)

FORMAT = "truthbench-results-1"
"""The ``format`` attribute of a results file; a single-test file has ``FORMAT + "/test"``."""


def _attrs(group, mapping):
    for k, v in mapping.items():
        group.attrs[k] = v


# ---- units -------------------------------------------------------------------------
def _set_unit(ds, unit) -> None:
    """``unit`` as a string, or an array of strings when its entries differ."""
    arr = np.asarray(unit, dtype=object)
    if arr.ndim == 0 or len(set(arr.ravel().tolist())) == 1:
        ds.attrs["unit"] = str(arr.ravel()[0]) if arr.ndim else str(arr)
    else:
        import h5py

        ds.attrs.create("unit", arr.astype(str).astype(object),
                        dtype=h5py.string_dtype("utf-8"))


def _dataset(group, name, data, unit, **kwargs):
    ds = group.create_dataset(name, data=data, **kwargs)
    _set_unit(ds, unit)
    return ds


def _frf_units(frf) -> np.ndarray:
    """Unit per (output, input) pair, shape (n_out, n_in)."""
    from truthbench.campaign.results import frf_unit

    return np.array([[frf_unit(o, i) for i in frf.inputs] for o in frf.outputs], dtype=object)


def _theta_units(names) -> list[str]:
    """Units of the uncertainty stage's ``f<k>_hz`` and ``zeta<k>`` parameters."""
    return ["Hz" if n.endswith("_hz") else "-" for n in names]


def _strings(group, name, values) -> None:
    import h5py

    group.create_dataset(name, data=np.array(list(values), dtype=object),
                         dtype=h5py.string_dtype("utf-8"))


# ---- writing -----------------------------------------------------------------------
def write_results(result, path: str | Path) -> Path:
    """Write a :class:`~truthbench.campaign.results.CampaignResult` to HDF5 (layout in
    the module docstring); the file appears complete or not at all."""
    import h5py

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".part")
    with h5py.File(tmp, "w") as f:
        _write_header(f, result.spec, result.seed, result.version, result.nominal,
                      len(result.trials))
        trials = f.create_group("trials")
        for tr in result.trials:
            _write_trial(trials, tr, result.spec)
    tmp.replace(path)
    return path


def _write_header(f, spec, seed: int, version: str, nominal: dict, n_trials: int) -> None:
    """The root attributes and ``/nominal`` of a results file."""
    _attrs(f, {
        "format": FORMAT, "truthbench_version": version, "seed": seed,
        "campaign": spec.campaign.name, "spec_json": json.dumps(spec.to_toml_dict()),
        "source": spec.source,
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "n_trials": n_trials})
    _attrs(f.create_group("nominal"), nominal)


def _write_trial(trials, tr, spec) -> None:
    """One :class:`~truthbench.campaign.results.TrialResult` as ``trials/<NNNN>``."""
    from truthbench.campaign.tables import parameter_unit

    def units(names):
        return [parameter_unit(spec, n) for n in names]

    g = trials.create_group(trial_key(tr.trial))
    g.attrs["status"] = "failed" if tr.error else "ok"
    g.attrs["error"] = tr.error or ""
    _attrs(g.create_group("truth"), tr.truth)
    _attrs(g.create_group("seconds"), tr.seconds)
    tests = g.create_group("tests")
    for rec in tr.tests:
        _write_test(tests.create_group(rec.name), rec)
    if tr.uncertainty is not None:
        _write_uncertainty(g.create_group("uncertainty"), tr.uncertainty)
    if tr.update is not None:
        _write_update(g.create_group("update"), tr.update, units)
        for method, res in tr.comparison.items():
            c = g.create_group(f"updates/{method}")
            if isinstance(res, str):
                c.attrs["error"] = res
            else:
                _write_update(c, res, units)
        for stage, acc in tr.accuracy.items():
            a = g.create_group(f"accuracy/{stage}")
            for key, value in acc.items():
                _dataset(a, key, value, _ACCURACY_UNITS.get(key, "-"))
        m = g.create_group("model")
        for rec, hi, hu, mask in zip(tr.tests, tr.H_initial, tr.H_updated,
                                     tr.update_mask, strict=True):
            mg = m.create_group(rec.name)
            fu = _frf_units(rec.frf)
            _dataset(mg, "H_initial", hi, fu)
            _dataset(mg, "H_updated", hu, fu)
            _dataset(mg, "update_mask", mask, "-")
    if getattr(tr, "frf_band", None) is not None:
        _write_frf_band(g.create_group("frf_band"), tr.frf_band, tr)


def trial_key(trial: int) -> str:
    """The group name of a trial under ``/trials`` (``0007``; more digits past 9999)."""
    return f"{int(trial):04d}"


_ACCURACY_UNITS = {"truth_freq_hz": "Hz", "freq_error_pct": "%", "damping_error_pct": "%",
                   "mac": "-", "n_unpaired_truth": "-"}


def write_test_record(record, path: str | Path, *, spec, seed: int, trial: int,
                      injected=()) -> Path:
    """Write one test (time histories, FRFs, truth record) to HDF5, in the layout of a
    test group of a results file, with the campaign spec and what was injected."""
    import h5py

    from truthbench._version import __version__

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        _attrs(f, {"format": FORMAT + "/test", "truthbench_version": __version__,
                   "seed": seed, "trial": trial, "campaign": spec.campaign.name,
                   "spec_json": json.dumps(spec.to_toml_dict()), "source": spec.source,
                   "injected": json.dumps(list(injected)),
                   "created_utc": datetime.now(UTC).isoformat(timespec="seconds")})
        _write_test(f.create_group(f"tests/{record.name}"), record)
    return path


def _write_test(t, rec) -> None:
    frf = rec.frf
    _dataset(t, "freq_hz", rec.freq_hz, "Hz")
    h = _dataset(t, "H", rec.H, _frf_units(frf))
    _attrs(h, {"n_averages": -1 if frf.n_averages is None else frf.n_averages,
               "band_hz": np.nan * np.ones(2) if frf.band_hz is None else frf.band_hz,
               "excitation": frf.excitation, "window_decay_rad_s": frf.window_decay_rad_s,
               "notes": json.dumps(list(frf.notes)),
               "estimator": json.dumps(None if frf.estimator is None
                                       else frf.estimator.to_dict()),
               "input_rms": json.dumps(None if frf.input_rms is None
                                       else list(frf.input_rms))})
    if rec.coherence is not None:
        _dataset(t, "coherence", rec.coherence, "-")
    for name, chans in (("u", frf.inputs), ("y", frf.outputs)):
        _dataset(t, name, getattr(rec, name), [c.unit for c in chans], compression="gzip",
                 compression_opts=4, shuffle=True)
    _attrs(t, {"fs_hz": rec.fs_hz, "input_labels": list(rec.input_labels),
               "output_labels": list(rec.output_labels)})
    for side, chans in (("outputs", frf.outputs), ("inputs", frf.inputs)):
        c = t.create_group(f"channels/{side}")
        for name in ("label", "quantity", "direction", "station", "unit"):
            _strings(c, name, [getattr(ch, name) or "" for ch in chans])
        _dataset(c, "sign", np.array([ch.sign for ch in chans], dtype=int), "-")
        _dataset(c, "point", np.array([-1 if ch.point is None else ch.point for ch in chans],
                                      dtype=int), "-")
        _dataset(c, "coordinates_m", np.array(
            [ch.coordinates_m or (np.nan,) * 3 for ch in chans], dtype=float).reshape(-1, 3),
            "m")
    _attrs(t.create_group("parameters"), rec.parameters)
    _write_modes(t, rec.modes)


def _write_update(u, res, units) -> None:
    u.create_dataset("names", data=np.array(res.names, dtype="S"))
    p = units(res.names)
    for name, unit in (("initial", p), ("values", p), ("history", p),
                       ("cost_history", "(weighted residual)^2"),
                       ("singular_values", "weighted residual per parameter unit"),
                       ("correlation", "-")):
        _dataset(u, name, getattr(res, name), unit)
    _attrs(u, {"converged": res.converged, "method": res.method,
               "condition_number": res.condition_number})


def _write_modes(group, modes) -> None:
    """Identified modes of a test under ``identified/`` (freq_hz, damping_ratio, shapes
    (n_out, n_modes) complex, displacement-equivalent, participation (n_modes, n_in))."""
    if modes is None:
        return
    g = group.create_group("identified")
    _dataset(g, "freq_hz", np.asarray(modes.freq_hz), "Hz")
    _dataset(g, "damping_ratio", np.asarray(modes.damping_ratio), "-")
    _dataset(g, "shapes", np.asarray(modes.shapes), "arb.")
    if getattr(modes, "participation", None) is not None:
        _dataset(g, "participation", np.asarray(modes.participation), "arb.")
    if getattr(modes, "output_labels", None) is not None:
        g.attrs["output_labels"] = list(modes.output_labels)


_UNCERTAINTY_FIELDS = ("theta_0", "theta_tests", "theta_truth", "mean", "std", "bound",
                       "inside", "mode_index", "holdout", "theta_updated")


def _write_uncertainty(st, stage) -> None:
    st.create_dataset("names", data=np.array(stage.names, dtype="S"))
    p = _theta_units(stage.names)
    for name in _UNCERTAINTY_FIELDS:
        value = getattr(stage, name)
        if value is not None:
            _dataset(st, name, value, "-" if name in ("inside", "mode_index", "holdout")
                     else p)


def _write_frf_band(g, stage, trial) -> None:
    b = stage.band
    rec = trial.test(stage.tests[0])
    fu = _frf_units(rec.frf)
    _strings(g, "tests", stage.tests)
    _dataset(g, "freq_hz", b.freq_hz, "Hz")
    _dataset(g, "mean", b.mean, fu)
    _dataset(g, "cov", b.cov, np.vectorize(lambda s: f"({s})^2", otypes=[object])(fu))
    _dataset(g, "line_mask", stage.line_mask, "-")
    _attrs(g, {"k_sigma": b.k_sigma, "n_tests": b.n_tests,
               "output_labels": list(stage.output_labels),
               "input_labels": list(stage.input_labels)})
    for which, frac in stage.inside.items():
        g.attrs[f"inside_{which}"] = frac


# ---- reading -----------------------------------------------------------------------
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


def _open(path: str | Path):
    """The open h5py file of a truthbench results (or single-test) file.

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
        f = h5py.File(path, "r")
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot be read as HDF5 ({exc})") from None
    fmt = f.attrs.get("format")
    if not str(_plain(fmt)).startswith(FORMAT):
        f.close()
        raise DataFormatError(f"{path}: not a truthbench results file (attribute "
                              f"'format' is {_plain(fmt)!r}; expected {FORMAT!r})")
    return f


def read_results(path: str | Path) -> dict:
    """Read a results file into nested dicts of arrays and attributes (the raw layout;
    :func:`load_results` gives the typed result).

    Raises
    ------
    DataFormatError
        If the file is missing, not HDF5, or not a truthbench results file.
    """
    path = Path(path)
    try:
        with _open(path) as f:
            data = _read_group(f)
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot be read as HDF5 ({exc})") from None
    data["attrs"]["spec"] = json.loads(data["attrs"]["spec_json"])
    if "trials" not in data and "tests" in data:  # a single-test file from 'simulate'
        data["attrs"]["single_test"] = True
    data["path"] = str(path)
    return data


def load_results(path: str | Path):
    """Rebuild the :class:`~truthbench.campaign.results.CampaignResult` of a results
    file (``CampaignResult.load``).

    A single-test file of ``truthbench simulate`` gives a result with one trial (its
    number from the file) holding the one test, an empty trial truth and no update;
    ``injected`` lists the effects injected. A run's folder gives its ``results.h5``,
    or, for a run that has not finished (interrupted, or still running), the trials its
    store holds (:class:`TrialStore`).

    Raises
    ------
    DataFormatError
        Naming the file (and the HDF5 path of a part that does not parse): missing, not
        HDF5, not a truthbench results file, a stored spec that is not a valid campaign.
    """
    path = Path(path)
    if path.is_dir():  # a run's folder: its results file, else its (partial) store
        if (path / RESULTS_FILE).is_file():
            path = path / RESULTS_FILE
        else:
            store = TrialStore(path.parent if path.name == TRIALS_DIR else path)
            if not store.exists:
                raise DataFormatError(f"{path}: holds neither {RESULTS_FILE} nor a run store "
                                      f"({TRIALS_DIR}/{RUN_FILE})")
            try:
                return store.load()
            except StoreError as exc:
                raise DataFormatError(str(exc)) from None
    where = str(path)
    try:
        with _open(path) as f:
            return _load(f, path)
    except DataFormatError:
        raise
    except (KeyError, ValueError, TypeError, OSError) as exc:
        raise DataFormatError(f"{where}: cannot be loaded as a truthbench result "
                              f"({type(exc).__name__}: {exc})") from None


class _Part(Exception):
    """A part of the file that does not parse: its HDF5 path and the cause."""


def _load(f, path: Path):
    from truthbench.campaign.results import CampaignResult, TrialResult
    from truthbench.campaign.spec import parse_campaign
    from truthbench.errors import CampaignError

    a = {k: _plain(v) for k, v in f.attrs.items()}
    try:
        spec = parse_campaign(json.loads(a["spec_json"]), source=a.get("source", str(path)))
    except (KeyError, json.JSONDecodeError, CampaignError) as exc:
        raise DataFormatError(f"{path}: attribute 'spec_json' is not a valid campaign "
                              f"({type(exc).__name__}: {exc})") from None
    order = {t.name: j for j, t in enumerate(spec.tests)}
    common = dict(spec=spec, seed=int(a["seed"]), version=str(a["truthbench_version"]),
                  created_utc=a.get("created_utc"), path=str(path))
    try:
        if str(a["format"]).endswith("/test"):
            tests = _read_tests(f["tests"], spec, order)
            trial = TrialResult(int(a.get("trial", 0)), tests, {})
            return CampaignResult(nominal=spec.nominal_parameters(), trials=(trial,),
                                  injected=tuple(json.loads(a.get("injected", "[]"))),
                                  **common)
        trials = tuple(_read_trial(f["trials"][k], spec, order)
                       for k in sorted(f["trials"], key=_trial_order))
        return CampaignResult(nominal=_attr_dict(f["nominal"]), trials=trials, **common)
    except _Part as exc:
        raise DataFormatError(f"{path}: {exc}") from None


def _trial_order(key: str):
    return (0, int(key)) if key.isdigit() else (1, key)


def _attr_dict(g) -> dict:
    return {k: _plain(v) for k, v in g.attrs.items()}


def _strs(values) -> tuple[str, ...]:
    return tuple(v.decode() if isinstance(v, bytes) else str(v) for v in np.ravel(values))


def _read_tests(group, spec, order) -> tuple:
    names = sorted(group, key=lambda n: (order.get(n, len(order)), n))
    return tuple(_read_test(group[n], spec, order.get(n)) for n in names)


def _channels(t, spec, j, side: str, labels):
    """The channels of one side of a stored test, or (older files) from the spec."""
    from truthbench.measure.frfdata import Channel

    if f"channels/{side}" in t:
        c = t[f"channels/{side}"]
        text = {name: _strs(c[name][()]) for name in ("label", "quantity", "direction",
                                                      "station", "unit")}
        signs, points, xyz_all = c["sign"][()], c["point"][()], c["coordinates_m"][()]
        out = []
        for k, label in enumerate(text["label"]):
            def s(name, k=k):
                return text[name][k] or None
            xyz = xyz_all[k]
            point = int(points[k])
            out.append(Channel(label, s("quantity"), s("direction"), int(signs[k]),
                               None if point < 0 else point,
                               None if not np.all(np.isfinite(xyz)) else tuple(xyz.tolist()),
                               s("station")))
        return tuple(out)
    from truthbench.plants import Actuator, Sensor

    if j is None:
        raise _Part(f"{t.name}: no stored channels and no test of that name in the spec")
    if side == "outputs":
        made = [(Sensor(s.station, s.direction, s.quantity).label, s.quantity, s.direction,
                 s.station) for s in spec.test_sensors(j)]
    else:
        made = [(Actuator(a.station, a.direction).label, "force", a.direction, a.station)
                for a in spec.tests[j].actuators]
    if tuple(m[0] for m in made) != tuple(labels):
        raise _Part(f"{t.name}: no stored channels, and the spec's {side} "
                    f"{[m[0] for m in made]} do not match the stored labels {list(labels)}")
    return tuple(Channel(lab, q, d, station=st) for lab, q, d, st in made)


def _read_test(t, spec, j):
    from truthbench.campaign.results import TestRecord
    from truthbench.measure.frfdata import FRFData

    name = t.name.rsplit("/", 1)[-1]
    try:
        attrs = _attr_dict(t)
        outputs = _channels(t, spec, j, "outputs", _strs(attrs["output_labels"]))
        inputs = _channels(t, spec, j, "inputs", _strs(attrs["input_labels"]))
        h = t["H"]
        ha = _attr_dict(h)
        if "n_averages" in ha:
            n_avg = None if ha["n_averages"] < 0 else int(ha["n_averages"])
            band = tuple(float(x) for x in ha["band_hz"])
            band = None if not np.all(np.isfinite(band)) else band
            meta = dict(n_averages=n_avg, band_hz=band, excitation=str(ha["excitation"]),
                        window_decay_rad_s=float(ha["window_decay_rad_s"]),
                        notes=tuple(json.loads(ha["notes"])))
            rms = json.loads(ha.get("input_rms", "null"))
            if rms is not None:
                meta["input_rms"] = tuple(rms)
            est = json.loads(ha.get("estimator", "null"))
            if est is not None:
                from truthbench.measure.leakage import Estimator

                meta["estimator"] = Estimator(**est)
        else:  # written before the FRF metadata was stored
            meta = dict(band_hz=None if j is None else tuple(spec.tests[j].band_hz))
        frf = FRFData(name, t["freq_hz"][()], h[()], outputs, inputs,
                      coherence=t["coherence"][()] if "coherence" in t else None, **meta)
        modes = None
        if "identified" in t:
            from truthbench.identify import ModalParameters

            g = t["identified"]
            labels = g.attrs.get("output_labels")
            modes = ModalParameters(
                g["freq_hz"][()], g["damping_ratio"][()], g["shapes"][()],
                g["participation"][()] if "participation" in g else None,
                None if labels is None else _strs(labels))
        return TestRecord(name, frf, t["u"][()], t["y"][()], float(attrs["fs_hz"]),
                          _attr_dict(t["parameters"]), modes)
    except _Part:
        raise
    except (KeyError, ValueError, TypeError) as exc:
        raise _Part(f"{t.name}: {type(exc).__name__}: {exc}") from None


def _read_update(u):
    from truthbench.update.finite_difference import UpdateResult

    a = _attr_dict(u)
    return UpdateResult(_strs(u["names"][()]), u["initial"][()], u["values"][()],
                        u["history"][()], u["cost_history"][()], u["singular_values"][()],
                        float(a["condition_number"]), u["correlation"][()],
                        bool(a["converged"]), str(a["method"]))


def _read_uncertainty(st):
    from truthbench.campaign.uncertainty_stage import UncertaintyStage

    v = {k: st[k][()] for k in _UNCERTAINTY_FIELDS if k in st}
    return UncertaintyStage(_strs(st["names"][()]), v["theta_0"], v["theta_tests"],
                            v["theta_truth"], v["mean"], v["std"], v["bound"], v["inside"],
                            v["mode_index"], v["holdout"], v.get("theta_updated"))


def _read_frf_band(g):
    from truthbench.campaign.frf_band_stage import FrfBandStage
    from truthbench.uncertainty.frequency import FrfUncertainty

    a = _attr_dict(g)
    band = FrfUncertainty(g["mean"][()], g["cov"][()], int(a["n_tests"]),
                          float(a["k_sigma"]), g["freq_hz"][()])
    inside = {k[len("inside_"):]: float(v) for k, v in a.items() if k.startswith("inside_")}
    inside = {k: inside[k] for k in ("initial", "updated") if k in inside}
    return FrfBandStage(_strs(g["tests"][()]), band, g["line_mask"][()], inside,
                        _strs(a["output_labels"]), _strs(a["input_labels"]))


def _read_trial(g, spec, order):
    from truthbench.campaign.results import TrialResult

    try:
        a = _attr_dict(g)
        tests = _read_tests(g["tests"], spec, order)
        methods = spec.update_methods()

        def by_method(keys):
            return sorted(keys, key=lambda m: (methods.index(m) if m in methods
                                               else len(methods), m))

        kw = {}
        if "update" in g:
            kw["update"] = _read_update(g["update"])
            comparison = {}
            for m in by_method(g.get("updates", {})):
                c = g["updates"][m]
                comparison[m] = str(c.attrs["error"]) if "error" in c.attrs else _read_update(c)
            kw["comparison"] = comparison
        if "accuracy" in g:
            acc = {}
            keys = list(g["accuracy"])
            for stage in (["initial"] if "initial" in keys else []) + by_method(
                    k for k in keys if k not in ("initial", "updated")) + (
                    ["updated"] if "updated" in keys else []):
                s = g["accuracy"][stage]
                acc[stage] = {k: (int(s[k][()]) if k == "n_unpaired_truth" else s[k][()])
                              for k in s}
            kw["accuracy"] = acc
        if "model" in g:
            m = g["model"]
            kw["H_initial"] = tuple(m[r.name]["H_initial"][()] for r in tests)
            kw["H_updated"] = tuple(m[r.name]["H_updated"][()] for r in tests)
            kw["update_mask"] = tuple(m[r.name]["update_mask"][()] for r in tests)
        if "uncertainty" in g:
            kw["uncertainty"] = _read_uncertainty(g["uncertainty"])
        if "frf_band" in g:
            kw["frf_band"] = _read_frf_band(g["frf_band"])
        return TrialResult(int(g.name.rsplit("/", 1)[-1]), tests, _attr_dict(g["truth"]),
                           error=str(a.get("error", "")) or None,
                           seconds={k: float(v) for k, v in _attr_dict(g["seconds"]).items()},
                           **kw)
    except _Part:
        raise
    except (KeyError, ValueError, TypeError) as exc:
        raise _Part(f"{g.name}: {type(exc).__name__}: {exc}") from None


# ------------------------------------------------------------------------------------
# The streaming store of a run: one file per finished trial, written atomically
# ------------------------------------------------------------------------------------

STORE_FORMAT = "truthbench-store-1"
"""The ``format`` of a run's ``trials/run.json``."""

TRIALS_DIR = "trials"
RUN_FILE = "run.json"
RESULTS_FILE = "results.h5"


class StoreError(TruthbenchError, OSError):
    """The store cannot be written or read (a full disk, an unwritable folder, a store of
    another run); the message names the path and what was expected."""


def trial_image(result_spec, seed: int, version: str, nominal: dict, trial) -> bytes:
    """One trial as the bytes of a results file holding that trial alone (the layout of
    :func:`write_results`, ``n_trials`` = 1), built in memory: workers make it, the main
    process only writes bytes (so a full disk is an ``OSError`` of an ordinary write,
    never an error inside HDF5)."""
    import h5py

    with h5py.File(f"trial-{trial.trial}.h5", "w", driver="core", backing_store=False) as f:
        _write_header(f, result_spec, seed, version, nominal, 1)
        _write_trial(f.create_group("trials"), trial, result_spec)
        f.flush()
        return bytes(f.id.get_file_image())


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory handles
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` so that the file appears whole or not at all: a
    ``.part`` file, flushed and fsynced, renamed over ``path``; on failure the ``.part``
    file is removed and the ``OSError`` raised."""
    tmp = path.with_name(path.name + ".part")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


class TrialStore:
    """The store of one run under ``folder``: ``trials/run.json`` (what the run is:
    campaign, seed, trial count, version) and ``trials/<NNNNNN>.h5``, one results file
    per finished trial, each written atomically (a crash leaves at most a ``.part`` file,
    which is ignored and removed). :meth:`consolidate` writes ``results.h5`` from them
    (trial by trial, never all in memory) and removes ``trials/``.

    Parameters
    ----------
    folder : str or pathlib.Path
        The run's output folder.
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        self.dir = self.folder / TRIALS_DIR
        self.run_path = self.dir / RUN_FILE

    # ---- what is there ----------------------------------------------------------
    @property
    def exists(self) -> bool:
        """Whether a (partial) store of trial files is there."""
        return self.run_path.exists()

    def header(self) -> dict:
        """The run's identity (``run.json``).

        Raises
        ------
        StoreError
            Missing or unreadable, or not a truthbench store.
        """
        try:
            head = json.loads(self.run_path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise StoreError(f"{self.run_path}: cannot be read as a truthbench run "
                             f"({type(exc).__name__}: {exc})") from None
        if head.get("format") != STORE_FORMAT:
            raise StoreError(f"{self.run_path}: not a truthbench run store (format "
                             f"{head.get('format')!r}; expected {STORE_FORMAT!r})")
        return head

    def trial_path(self, trial: int) -> Path:
        return self.dir / f"{int(trial):06d}.h5"

    def done(self) -> list[int]:
        """Trials stored, ascending (finished files only; ``.part`` files are not)."""
        if not self.dir.is_dir():
            return []
        out = []
        for p in self.dir.iterdir():
            if p.suffix == ".h5" and p.stem.isdigit():
                out.append(int(p.stem))
        return sorted(out)

    # ---- writing ----------------------------------------------------------------
    def create(self, spec, seed: int, n_trials: int, version: str) -> dict:
        """Start a new store (the folder must not hold one)."""
        head = {"format": STORE_FORMAT, "campaign": spec.campaign.name,
                "spec_json": json.dumps(spec.to_toml_dict(), sort_keys=True),
                "source": spec.source, "seed": int(seed), "trials": int(n_trials),
                "truthbench_version": version,
                "created_utc": datetime.now(UTC).isoformat(timespec="seconds")}
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            write_atomic(self.run_path, json.dumps(head, indent=1).encode())
        except OSError as exc:
            raise StoreError(f"{self.dir}: cannot start the results store "
                             f"({exc.strerror or exc}); choose a writable folder with "
                             f"--out") from None
        return head

    def check(self, spec, seed: int, n_trials: int) -> dict:
        """The stored header, after checking that it is the same run (same campaign,
        seed and trial count).

        Raises
        ------
        StoreError
            Naming what differs: the stored value against the requested one.
        """
        head = self.header()
        want = {"campaign (spec)": json.dumps(spec.to_toml_dict(), sort_keys=True),
                "seed": int(seed), "trials": int(n_trials)}
        have = {"campaign (spec)": head.get("spec_json"), "seed": head.get("seed"),
                "trials": head.get("trials")}
        bad = [k for k in want if want[k] != have[k]]
        if bad:
            detail = "; ".join(
                f"{k}: stored {have[k]!r}, requested {want[k]!r}" if k != "campaign (spec)"
                else "campaign: the stored campaign differs from the file's "
                     f"(stored from {head.get('source')!r})" for k in bad)
            raise StoreError(f"{self.folder}: --resume needs the run the store holds; "
                             f"{detail}. Run with the stored settings, or --force to "
                             f"start over")
        return head

    def write(self, trial: int, image: bytes) -> Path:
        """Store one finished trial (bytes of :func:`trial_image`) atomically.

        Raises
        ------
        StoreError
            The write failed (full disk, permissions); the trials already stored are
            untouched.
        """
        path = self.trial_path(trial)
        try:
            write_atomic(path, image)
        except OSError as exc:
            kept = len(self.done())
            why = exc.strerror or str(exc)
            if exc.errno == errno.ENOSPC:
                why = "no space left on device"
            raise StoreError(
                f"{path}: cannot store trial {trial} ({why}; {len(image) / 1e6:.1f} MB); "
                f"the {kept} trial(s) already stored in {self.dir} are kept: free space "
                f"and continue with --resume") from None
        return path

    def clean_partial(self) -> int:
        """Remove ``.part`` files a crash left; returns how many."""
        n = 0
        if self.dir.is_dir():
            for p in self.dir.glob("*.part"):
                p.unlink(missing_ok=True)
                n += 1
        return n

    # ---- reading ----------------------------------------------------------------
    def stored_bytes(self) -> int:
        return sum(self.trial_path(t).stat().st_size for t in self.done())

    def load(self):
        """The stored trials as a :class:`~truthbench.campaign.results.CampaignResult`
        (all in memory; a partial store gives the trials it holds)."""
        from dataclasses import replace

        head = self.header()
        trials, first = [], None
        for t in self.done():
            res = load_results(self.trial_path(t))
            first = first or res
            trials.extend(res.trials)
        if first is None:
            from truthbench.campaign.results import CampaignResult
            from truthbench.campaign.spec import parse_campaign

            spec = parse_campaign(json.loads(head["spec_json"]), source=head.get("source"))
            return CampaignResult(spec, int(head["seed"]), head["truthbench_version"],
                                  spec.nominal_parameters(), (), path=str(self.dir))
        return replace(first, trials=tuple(trials), path=str(self.dir),
                       created_utc=head.get("created_utc"))

    def consolidate(self, path: str | Path | None = None, *, remove: bool = True) -> Path:
        """Write the stored trials to one results file (layout of :func:`write_results`),
        copying trial by trial (memory does not grow with the trial count); then remove
        ``trials/`` unless ``remove`` is False.

        Raises
        ------
        StoreError
            Not enough free space (checked first), or the write failed; the trial files
            are kept then.
        """
        import h5py

        path = Path(path) if path is not None else self.folder / RESULTS_FILE
        head = self.header()
        done = self.done()
        need = self.stored_bytes()
        free = shutil.disk_usage(path.parent).free
        if need * 1.1 + 1e6 > free:
            raise StoreError(f"{path}: not enough free space to write the results file "
                             f"(about {need / 1e6:.0f} MB needed, {free / 1e6:.0f} MB "
                             f"free); the {len(done)} stored trial(s) are kept in "
                             f"{self.dir}")
        tmp = path.with_name(path.name + ".part")
        try:
            with h5py.File(tmp, "w") as out:
                nominal = None
                trials = out.create_group("trials")
                for t in done:
                    with h5py.File(self.trial_path(t), "r") as src:
                        if nominal is None:
                            for k, v in src.attrs.items():
                                out.attrs[k] = v
                            out.copy(src["nominal"], "nominal")
                            nominal = True
                        for key in src["trials"]:
                            src.copy(src["trials"][key], trials, name=key)
                if nominal is None:
                    out.attrs.update({"format": FORMAT, "seed": head["seed"],
                                      "campaign": head["campaign"],
                                      "spec_json": head["spec_json"],
                                      "source": head.get("source", ""),
                                      "truthbench_version": head["truthbench_version"]})
                    out.create_group("nominal")
                out.attrs["n_trials"] = len(done)
                out.attrs["n_trials_requested"] = int(head["trials"])
                out.attrs["created_utc"] = datetime.now(UTC).isoformat(timespec="seconds")
            os.replace(tmp, path)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise StoreError(f"{path}: cannot write the results file ({exc}); the "
                             f"{len(done)} stored trial(s) are kept in {self.dir}") from None
        if remove:
            shutil.rmtree(self.dir, ignore_errors=True)
        return path


# ------------------------------------------------------------------------------------
# The FRFData reader of results and 'simulate' files, registered with truthbench.io for
# .h5 and .hdf5 when this module is imported.
# ------------------------------------------------------------------------------------


def read_frf(path: str | Path, *, trials=None, tests=None) -> tuple:
    """The FRFs of a results file or a 'simulate' file as FRFData (the ``.h5`` reader of
    :func:`truthbench.io.load_frf`).

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
        One per (trial, test), named ``"trial <k> / <test>"``, as
        :meth:`~truthbench.campaign.results.CampaignResult.load` rebuilds them: channels
        with quantity, direction, station and coordinates, coherence, averages, band and
        the estimator's settings.

    Raises
    ------
    DataFormatError
        Naming the file: not a truthbench results file, a trial or test it does not
        hold, no stored FRF.
    """
    from dataclasses import replace

    result = load_results(path)
    want_trials = None if trials is None else (
        {int(trials)} if isinstance(trials, int | np.integer) else {int(t) for t in trials})
    want_tests = None if tests is None else (
        {tests} if isinstance(tests, str) else {str(t) for t in tests})
    held_trials = sorted(t.trial for t in result.trials)
    held_tests = sorted({r.name for t in result.trials for r in t.tests})
    if want_trials is not None and want_trials - set(held_trials):
        raise DataFormatError(f"{path}: no trial {sorted(want_trials - set(held_trials))} "
                              f"in the file; it holds trials {held_trials}")
    if want_tests is not None and want_tests - set(held_tests):
        raise DataFormatError(f"{path}: no test {sorted(want_tests - set(held_tests))} in "
                              f"the file; it holds tests {held_tests}")
    out = tuple(replace(rec.frf, name=f"trial {tr.trial} / {rec.name}")
                for tr in result.trials if want_trials is None or tr.trial in want_trials
                for rec in tr.tests if want_tests is None or rec.name in want_tests)
    if not out:
        raise DataFormatError(f"{path}: the file holds no test with stored FRFs; expected "
                              f"at least one")
    return out


for _ext in (".h5", ".hdf5"):
    register_reader(_ext, read_frf)
