"""truthbench's HDF5 files: a campaign run's results and a single simulated test.

This module is the format: its layout, writing it, reading it back as plain data, and
:func:`read_frf`, the ``.h5`` / ``.hdf5`` reader of :func:`truthbench.io.load_frf`
(registered by :mod:`truthbench.io`). It knows nothing of campaigns: what it needs of
one (the spec as JSON, the units of the update parameters) is passed in as plain data,
and what it reads comes back as dicts, arrays and :class:`~truthbench.measure.FRFData`.
The campaign room (:mod:`truthbench.campaign.store`) writes its results through it and
builds its typed :class:`~truthbench.campaign.results.CampaignResult` from what it reads.

Layout (SI units; FRFs complex (n_freq, n_out, n_in); strings UTF-8)::

    /                      attrs: format, truthbench_version, seed, campaign, spec_json,
                                  source, created_utc, n_trials
    /nominal               attrs: parameter -> value (unit in the name: E_pa, rho_kg_m3)
    /trials/0000           attrs: status ("ok" | "failed"), error
        summary            dataset: a JSON string, what the tables and the report
                           reduce over (written by the campaign room:
                           truthbench.campaign.summary; absent in older files)
        truth              attrs: parameter -> value
        seconds            attrs: stage -> wall-clock seconds, s
        tests/<name>       datasets freq_hz, H, coherence, u, y (u, y have 0 samples for
                           trials whose time histories the campaign's [output] does not
                           keep); attrs fs_hz, input_labels, output_labels;
                           H attrs: n_averages, band_hz, excitation, window_decay_rad_s,
                           notes, estimator, input_rms (the FRFData's)
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
        frf_band           the FRF-domain band: datasets tests, freq_hz, mean,
                           cov (n_freq, n_out, n_in, 2, 2), line_mask; attrs k_sigma,
                           n_tests, output_labels, input_labels, inside_initial,
                           inside_updated (fractions in [0, 1])

A single-test file (``truthbench simulate``) has ``format`` ``FORMAT + "/test"``, the
attrs ``trial`` and ``injected`` (JSON list of the effects injected) and one
``tests/<name>`` group at the root. A run's trial file (:func:`results_image`) is a
results file holding one trial.

Units: every numeric dataset carries a ``unit`` attribute: ``"Hz"``, ``"s"``, ``"m"``,
``"%"``, ``"-"`` (dimensionless: ratios, MAC, coherence, masks, counts, indices), the
FRF unit from the channels (output unit per input unit: ``"m/s^2/N"``,
``"rad/s/(N m)"``, :func:`frf_unit`), an update parameter's unit (``"Pa"``,
``"kg/m^3"``). When the entries of one dataset differ, ``unit`` is an array of strings:
per channel pair (shape (n_out, n_in)) for FRFs, per channel (one per row) for ``u`` and
``y``, per parameter (one per ``names`` entry) for parameter vectors and tables. The
cost of an update is ``"(weighted residual)^2"`` and its singular values ``"weighted
residual per parameter unit"``: their units depend on the weighting. Identified
``shapes`` and ``participation`` are ``"arb."``: their product is the
displacement-equivalent residue, the split of its scale between them is arbitrary.
Attributes holding numbers have their unit in their name (``fs_hz``, ``E_pa``) or in
this docstring.

A failed trial is written with what it had computed, so nothing is lost. Files written
before channels and FRF metadata were stored need them from their campaign
(``legacy`` of :func:`read_body`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from truthbench.errors import DataFormatError

FORMAT = "truthbench-results-1"
"""The ``format`` attribute of a results file; a single-test file has ``FORMAT + "/test"``."""

HEADER_KEYS = ("truthbench_version", "seed", "campaign", "spec_json", "source")
"""What a file says of the run that made it (root attributes), given to the writers as a
dict: the package version, the seed, the campaign's name, its spec (JSON) and source."""


def frf_unit(output, input) -> str:  # noqa: A002 - the FRF's input channel
    """The unit of an FRF from ``input`` to ``output``
    (:class:`~truthbench.measure.frfdata.Channel`): ``"m/s^2/N"``, ``"rad/s/(N m)"``."""
    den = input.unit
    return f"{output.unit}/({den})" if " " in den else f"{output.unit}/{den}"


def _frf_units(frf) -> np.ndarray:
    """Unit per (output, input) pair, shape (n_out, n_in)."""
    return np.array([[frf_unit(o, i) for i in frf.inputs] for o in frf.outputs], dtype=object)


def _theta_units(names) -> list[str]:
    """Units of the uncertainty stage's ``f<k>_hz`` and ``zeta<k>`` parameters."""
    return ["Hz" if n.endswith("_hz") else "-" for n in names]


def _attrs(group, mapping):
    for k, v in mapping.items():
        group.attrs[k] = v


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


def _strings(group, name, values) -> None:
    import h5py

    group.create_dataset(name, data=np.array(list(values), dtype=object),
                         dtype=h5py.string_dtype("utf-8"))


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


# ---- writing -----------------------------------------------------------------------
def write_results(path: str | Path, head: Mapping, nominal: Mapping, trials,
                  units: Mapping[str, str], summary=None) -> Path:
    """Write a run's results (layout in the module docstring); the file appears complete
    or not at all.

    Parameters
    ----------
    path : str or pathlib.Path
    head : mapping
        The root attributes :data:`HEADER_KEYS`.
    nominal : mapping of str -> float
        The nominal parameters.
    trials : sequence of TrialResult
        Read through their attributes (:class:`~truthbench.campaign.results.TrialResult`).
    units : mapping of str -> str
        The unit of every update parameter (``""`` for one not listed).
    summary : callable, optional
        ``summary(trial) -> str``: a trial's summary as JSON text (the ``summary``
        dataset).
    """
    import h5py

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".part")
    with h5py.File(tmp, "w") as f:
        _write_header(f, head, nominal, len(trials))
        group = f.create_group("trials")
        for tr in trials:
            _write_trial(group, tr, units, None if summary is None else summary(tr))
    tmp.replace(path)
    return path


def results_image(head: Mapping, nominal: Mapping, trial, units: Mapping[str, str],
                  summary: str | None = None) -> bytes:
    """One trial as the bytes of a results file holding that trial alone (``n_trials``
    = 1; arguments as :func:`write_results`, ``summary`` the trial's summary as JSON
    text), built in memory: a worker makes it, the
    process that stores it only writes bytes (so a full disk is an ``OSError`` of an
    ordinary write, never an error inside HDF5)."""
    import h5py

    with h5py.File(f"trial-{trial.trial}.h5", "w", driver="core", backing_store=False) as f:
        _write_header(f, head, nominal, 1)
        _write_trial(f.create_group("trials"), trial, units, summary)
        f.flush()
        return bytes(f.id.get_file_image())


def write_test_file(path: str | Path, record, head: Mapping, *, trial: int,
                    injected=()) -> Path:
    """Write one test (time histories, FRFs, truth record) in the layout of a test group
    of a results file, with the run's ``head`` (:data:`HEADER_KEYS`), the trial and the
    effects injected (their ``--inject`` texts)."""
    import h5py

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        _attrs(f, {"format": FORMAT + "/test", **_header(head), "trial": trial,
                   "injected": json.dumps(list(injected)), "created_utc": _now()})
        _write_test(f.create_group(f"tests/{record.name}"), record)
    return path


def _header(head: Mapping) -> dict:
    missing = [k for k in HEADER_KEYS if k not in head]
    if missing:
        raise ValueError(f"the file header lacks {missing}; expected {list(HEADER_KEYS)}")
    return {k: head[k] for k in HEADER_KEYS}


def _write_header(f, head: Mapping, nominal: Mapping, n_trials: int) -> None:
    """The root attributes and ``/nominal`` of a results file."""
    _attrs(f, {"format": FORMAT, **_header(head), "created_utc": _now(),
               "n_trials": n_trials})
    _attrs(f.create_group("nominal"), nominal)


def trial_key(trial: int) -> str:
    """The group name of a trial under ``/trials`` (``0007``; more digits past 9999)."""
    return f"{int(trial):04d}"


_ACCURACY_UNITS = {"truth_freq_hz": "Hz", "freq_error_pct": "%", "damping_error_pct": "%",
                   "mac": "-", "n_unpaired_truth": "-"}


def _write_trial(trials, tr, units: Mapping[str, str], summary: str | None = None) -> None:
    """One trial as ``trials/<NNNN>``."""
    g = trials.create_group(trial_key(tr.trial))
    g.attrs["status"] = "failed" if tr.error else "ok"
    g.attrs["error"] = tr.error or ""
    if summary is not None:
        import h5py

        g.create_dataset("summary", data=summary, dtype=h5py.string_dtype("utf-8"))
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


_UPDATE_FIELDS = ("names", "initial", "values", "history", "cost_history",
                  "singular_values", "condition_number", "correlation", "converged",
                  "method")
"""The fields of an update result, in the order of
:class:`~truthbench.update.finite_difference.UpdateResult`."""


def _write_update(u, res, units: Mapping[str, str]) -> None:
    u.create_dataset("names", data=np.array(res.names, dtype="S"))
    p = [units.get(n, "") for n in res.names]
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
class _Part(Exception):
    """A part of the file that does not parse: its HDF5 path and the cause."""


def _plain(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.dtype.kind in "OS":
        return [x.decode() if isinstance(x, bytes) else x for x in v.tolist()]
    if isinstance(v, np.generic):
        return v.item()
    return v


def _attr_dict(g) -> dict:
    return {k: _plain(v) for k, v in g.attrs.items()}


def _strs(values) -> tuple[str, ...]:
    return tuple(v.decode() if isinstance(v, bytes) else str(v) for v in np.ravel(values))


METADATA_CACHE_BYTES = 2 << 20
"""Largest metadata cache of a results file truthbench opens (HDF5's default initial
size). HDF5 lets a file's cache grow to 32 MB, which a pass over ten thousand trial
groups fills, and the library's memory around it grew by 175 MB; reading them in order
gains nothing from a larger cache (the same 3.3 s)."""


def limit_metadata_cache(f) -> None:
    """Cap the metadata cache of an open h5py file at :data:`METADATA_CACHE_BYTES`, so
    that a pass over every trial of a large results file keeps its memory flat."""
    c = f.id.get_mdc_config()
    c.set_initial_size = True
    c.initial_size = min(c.initial_size, METADATA_CACHE_BYTES)
    c.min_size = min(c.min_size, METADATA_CACHE_BYTES)
    c.max_size = METADATA_CACHE_BYTES
    f.id.set_mdc_config(c)


def open_results(path: str | Path):
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
    limit_metadata_cache(f)
    return f


@contextmanager
def reading(path: str | Path):
    """``with reading(path) as f``: :func:`open_results`, with every failure to read a
    part (a missing dataset, a malformed attribute) raised as a
    :class:`~truthbench.errors.DataFormatError` naming the file and the HDF5 path."""
    path = Path(path)
    f = open_results(path)
    try:
        with f:
            yield f
    except DataFormatError:
        raise
    except _Part as exc:
        raise DataFormatError(f"{path}: {exc}") from None
    except (KeyError, ValueError, TypeError, OSError) as exc:
        raise DataFormatError(f"{path}: cannot be loaded as a truthbench result "
                              f"({type(exc).__name__}: {exc})") from None


def read_attrs(f) -> dict:
    """The root attributes of an open file (:func:`reading`), with ``spec`` (the
    decoded ``spec_json``) and ``single_test`` (a 'simulate' file) added."""
    a = _attr_dict(f)
    try:
        a["spec"] = json.loads(a["spec_json"])
    except (KeyError, TypeError, json.JSONDecodeError) as exc:
        raise DataFormatError(f"{f.filename}: attribute 'spec_json' is not the campaign "
                              f"as JSON ({type(exc).__name__}: {exc})") from None
    a["single_test"] = str(a["format"]).endswith("/test")
    return a


def read_body(f, attrs: Mapping, legacy: Mapping | None = None) -> dict:
    """Everything an open file (:func:`reading`) holds as plain data.

    Parameters
    ----------
    f : h5py.File
    attrs : mapping
        Its :func:`read_attrs`.
    legacy : mapping, optional
        Test name -> ``{"outputs": tuple of Channel, "inputs": tuple of Channel,
        "band_hz": (lo, hi)}``: what files written before channels and FRF metadata were
        stored lack (their campaign knows it).

    Returns
    -------
    dict
        ``nominal`` (dict; None for a single-test file) and ``trials``: per trial a dict
        with the fields of :class:`~truthbench.campaign.results.TrialResult`
        (``trial``, ``tests``, ``truth``, ``error``, ``seconds``, and where stored
        ``update``, ``comparison``, ``accuracy``, ``H_initial``, ``H_updated``,
        ``update_mask``, ``uncertainty``, ``frf_band``), updates, uncertainty and band
        as dicts of their fields, ``comparison`` and ``accuracy`` in file order; per test
        a dict with the fields of :class:`~truthbench.campaign.results.TestRecord`
        (``frf`` an FRFData, ``modes`` a dict or None). Tests come in the order of the
        stored campaign's tests.
    """
    order = {t.get("name"): j for j, t in enumerate(attrs["spec"].get("tests", []))}
    legacy = legacy or {}
    if attrs["single_test"]:
        trial = {"trial": int(attrs.get("trial", 0)), "tests": _read_tests(f["tests"], order,
                                                                          legacy),
                 "truth": {}}
        return {"nominal": None, "trials": [trial]}
    trials = [_read_trial(f["trials"][k], order, legacy) for k in trial_keys(f)]
    return {"nominal": read_nominal(f), "trials": trials}


def read_nominal(f) -> dict:
    """The nominal parameters (``/nominal``) of an open results file."""
    return _attr_dict(f["nominal"])


def trial_keys(f) -> list[str]:
    """The group names under ``/trials`` of an open results file, in trial order."""
    return sorted(f["trials"], key=_trial_order)


def read_trial(f, key: str, attrs: Mapping, legacy: Mapping | None = None) -> dict:
    """One trial (group ``/trials/<key>``) of an open results file as plain data, as an
    entry of :func:`read_body`'s ``trials`` (with ``summary``, the JSON text or None)."""
    order = {t.get("name"): j for j, t in enumerate(attrs["spec"].get("tests", []))}
    return _read_trial(f["trials"][key], order, legacy or {})


def read_summary(f, key: str) -> tuple[str | None, dict]:
    """The ``summary`` (JSON text; None for a file written before trials had one) and the
    stage ``seconds`` of trial ``key`` of an open results file."""
    g = f["trials"][key]
    seconds = {k: float(v) for k, v in _attr_dict(g["seconds"]).items()}
    return (_plain(g["summary"][()]) if "summary" in g else None), seconds


def read_results(path: str | Path) -> dict:
    """Read a results file into nested dicts of arrays and attributes (the raw layout;
    :meth:`CampaignResult.load <truthbench.campaign.results.CampaignResult.load>` gives
    the typed result).

    Raises
    ------
    DataFormatError
        If the file is missing, not HDF5, or not a truthbench results file.
    """
    def group(g) -> dict:
        out = {"attrs": _attr_dict(g)}
        for k, v in g.items():
            out[k] = group(v) if hasattr(v, "keys") else v[()]
        return out

    path = Path(path)
    try:
        with open_results(path) as f:
            data = group(f)
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot be read as HDF5 ({exc})") from None
    data["attrs"]["spec"] = json.loads(data["attrs"]["spec_json"])
    if "trials" not in data and "tests" in data:  # a single-test file from 'simulate'
        data["attrs"]["single_test"] = True
    data["path"] = str(path)
    return data


def _trial_order(key: str):
    return (0, int(key)) if key.isdigit() else (1, key)


def _read_tests(group, order, legacy) -> list[dict]:
    names = sorted(group, key=lambda n: (order.get(n, len(order)), n))
    return [_read_test(group[n], legacy.get(n)) for n in names]


def _channels(t, side: str, labels, legacy) -> tuple:
    """The channels of one side of a stored test, or (older files) ``legacy``'s."""
    from truthbench.measure.frfdata import Channel

    if f"channels/{side}" not in t:
        if legacy is None:
            raise _Part(f"{t.name}: no stored channels (a file written before they were "
                        f"stored) and none given for this test by its campaign")
        made = tuple(legacy[side])
        if tuple(c.label for c in made) != tuple(labels):
            raise _Part(f"{t.name}: no stored channels, and the campaign's {side} "
                        f"{[c.label for c in made]} do not match the stored labels "
                        f"{list(labels)}")
        return made
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


def _read_test(t, legacy) -> dict:
    from truthbench.measure.frfdata import FRFData

    name = t.name.rsplit("/", 1)[-1]
    try:
        attrs = _attr_dict(t)
        outputs = _channels(t, "outputs", _strs(attrs["output_labels"]), legacy)
        inputs = _channels(t, "inputs", _strs(attrs["input_labels"]), legacy)
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
            meta = dict(band_hz=None if legacy is None else tuple(legacy["band_hz"]))
        frf = FRFData(name, t["freq_hz"][()], h[()], outputs, inputs,
                      coherence=t["coherence"][()] if "coherence" in t else None, **meta)
        modes = None
        if "identified" in t:
            g = t["identified"]
            labels = g.attrs.get("output_labels")
            modes = {"freq_hz": g["freq_hz"][()], "damping_ratio": g["damping_ratio"][()],
                     "shapes": g["shapes"][()],
                     "participation": g["participation"][()] if "participation" in g
                     else None,
                     "output_labels": None if labels is None else _strs(labels)}
        return {"name": name, "frf": frf, "u": t["u"][()], "y": t["y"][()],
                "fs_hz": float(attrs["fs_hz"]), "parameters": _attr_dict(t["parameters"]),
                "modes": modes}
    except _Part:
        raise
    except (KeyError, ValueError, TypeError) as exc:
        raise _Part(f"{t.name}: {type(exc).__name__}: {exc}") from None


def _read_update(u) -> dict:
    a = _attr_dict(u)
    return {"names": _strs(u["names"][()]), "initial": u["initial"][()],
            "values": u["values"][()], "history": u["history"][()],
            "cost_history": u["cost_history"][()],
            "singular_values": u["singular_values"][()],
            "condition_number": float(a["condition_number"]),
            "correlation": u["correlation"][()], "converged": bool(a["converged"]),
            "method": str(a["method"])}


def _read_uncertainty(st) -> dict:
    v = {k: st[k][()] for k in _UNCERTAINTY_FIELDS if k in st}
    v.setdefault("theta_updated", None)
    return {"names": _strs(st["names"][()]), **{k: v[k] for k in _UNCERTAINTY_FIELDS}}


def _read_frf_band(g) -> dict:
    a = _attr_dict(g)
    inside = {k[len("inside_"):]: float(v) for k, v in a.items() if k.startswith("inside_")}
    return {"tests": _strs(g["tests"][()]), "mean": g["mean"][()], "cov": g["cov"][()],
            "n_tests": int(a["n_tests"]), "k_sigma": float(a["k_sigma"]),
            "freq_hz": g["freq_hz"][()], "line_mask": g["line_mask"][()],
            "inside": {k: inside[k] for k in ("initial", "updated") if k in inside},
            "output_labels": _strs(a["output_labels"]),
            "input_labels": _strs(a["input_labels"])}


def _read_trial(g, order, legacy) -> dict:
    try:
        a = _attr_dict(g)
        tests = _read_tests(g["tests"], order, legacy)
        out = {"trial": int(g.name.rsplit("/", 1)[-1]), "tests": tests,
               "truth": _attr_dict(g["truth"]), "error": str(a.get("error", "")) or None,
               "seconds": {k: float(v) for k, v in _attr_dict(g["seconds"]).items()},
               "summary": _plain(g["summary"][()]) if "summary" in g else None}
        if "update" in g:
            out["update"] = _read_update(g["update"])
            out["comparison"] = {
                m: str(c.attrs["error"]) if "error" in c.attrs else _read_update(c)
                for m, c in g.get("updates", {}).items()}
        if "accuracy" in g:
            out["accuracy"] = {
                stage: {k: (int(s[k][()]) if k == "n_unpaired_truth" else s[k][()])
                        for k in s} for stage, s in g["accuracy"].items()}
        if "model" in g:
            m = g["model"]
            for key in ("H_initial", "H_updated", "update_mask"):
                out[key] = tuple(m[r["name"]][key][()] for r in tests)
        if "uncertainty" in g:
            out["uncertainty"] = _read_uncertainty(g["uncertainty"])
        if "frf_band" in g:
            out["frf_band"] = _read_frf_band(g["frf_band"])
        return out
    except _Part:
        raise
    except (KeyError, ValueError, TypeError) as exc:
        raise _Part(f"{g.name}: {type(exc).__name__}: {exc}") from None


# ---- the .h5 / .hdf5 reader of truthbench.io.load_frf --------------------------------
def read_frf(path: str | Path, *, trials=None, tests=None) -> tuple:
    """The FRFs of a results file or a 'simulate' file as FRFData (the ``.h5`` reader of
    :func:`truthbench.io.load_frf`).

    Parameters
    ----------
    path : str or pathlib.Path
        A results file or a single-test file (:func:`write_results`,
        :func:`write_test_file`).
    trials : int or sequence of int, optional
        Only these trials (default: all).
    tests : str or sequence of str, optional
        Only these tests, by name (default: all).

    Returns
    -------
    tuple of FRFData
        One per (trial, test), named ``"trial <k> / <test>"``, in the campaign's test
        order: channels with quantity, direction, station and coordinates, coherence,
        averages, band and the estimator's settings.

    Raises
    ------
    DataFormatError
        Naming the file: not a truthbench results file, a trial or test it does not
        hold, no stored FRF.
    """
    from dataclasses import replace

    with reading(path) as f:
        held = read_body(f, read_attrs(f))["trials"]
    want_trials = None if trials is None else (
        {int(trials)} if isinstance(trials, int | np.integer) else {int(t) for t in trials})
    want_tests = None if tests is None else (
        {tests} if isinstance(tests, str) else {str(t) for t in tests})
    held_trials = sorted(t["trial"] for t in held)
    held_tests = sorted({r["name"] for t in held for r in t["tests"]})
    if want_trials is not None and want_trials - set(held_trials):
        raise DataFormatError(f"{path}: no trial {sorted(want_trials - set(held_trials))} "
                              f"in the file; it holds trials {held_trials}")
    if want_tests is not None and want_tests - set(held_tests):
        raise DataFormatError(f"{path}: no test {sorted(want_tests - set(held_tests))} in "
                              f"the file; it holds tests {held_tests}")
    out = tuple(replace(rec["frf"], name=f"trial {tr['trial']} / {rec['name']}")
                for tr in held if want_trials is None or tr["trial"] in want_trials
                for rec in tr["tests"] if want_tests is None or rec["name"] in want_tests)
    if not out:
        raise DataFormatError(f"{path}: the file holds no test with stored FRFs; expected "
                              f"at least one")
    return out
