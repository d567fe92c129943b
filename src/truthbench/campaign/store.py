"""A run's results on disk: the streaming store of its trials, and its results file.

A run streams its trials to a :class:`TrialStore` first: ``<folder>/trials/run.json``
(the run's identity: format ``truthbench-store-1``, campaign spec, seed, trial count,
version) and ``<folder>/trials/<NNNNNN>.h5``, one results file per finished trial
(``n_trials`` = 1), written atomically (``.part``, fsync, rename); gathered into
``results.h5`` (attribute ``n_trials_requested`` added) when every trial is stored.

The files are truthbench's HDF5 format (:mod:`truthbench.io.hdf5`, where the layout is
described): :func:`write_results` writes a
:class:`~truthbench.campaign.results.CampaignResult` through it, :func:`trial_image`
one trial of a run, :func:`write_test_record` the single-test file of ``truthbench
simulate``; :meth:`CampaignResult.load
<truthbench.campaign.results.CampaignResult.load>` reads them back, typed.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

from truthbench.errors import TruthbenchError
from truthbench.io import hdf5

STORE_FORMAT = "truthbench-store-1"
"""The ``format`` of a run's ``trials/run.json``."""

TRIALS_DIR = "trials"
RUN_FILE = "run.json"
RESULTS_FILE = "results.h5"


class StoreError(TruthbenchError, OSError):
    """The store cannot be written or read (a full disk, an unwritable folder, a store of
    another run); the message names the path and what was expected."""


# ---- the campaign's side of the format --------------------------------------------------
def _head(spec, seed: int, version: str) -> dict:
    """The root attributes a file gets from its run (:data:`truthbench.io.hdf5.HEADER_KEYS`)."""
    return {"truthbench_version": version, "seed": seed, "campaign": spec.campaign.name,
            "spec_json": json.dumps(spec.to_toml_dict()), "source": spec.source}


def _units(spec) -> dict[str, str]:
    """The unit of every update parameter of ``spec``."""
    from truthbench.campaign.tables import parameter_unit

    return {n: parameter_unit(spec, n) for n in spec.update.parameters}


def _summary_json(spec, trial) -> str:
    """A trial's summary as JSON text: its own, or computed from it
    (:mod:`truthbench.campaign.summary`)."""
    from truthbench.campaign.summary import trial_summary

    return (trial.summary if trial.summary is not None
            else trial_summary(spec, trial)).to_json()


def write_results(result, path: str | Path) -> Path:
    """Write a :class:`~truthbench.campaign.results.CampaignResult` to HDF5
    (:func:`truthbench.io.hdf5.write_results`), every trial with its summary, one trial
    in memory at a time; the file appears complete or not at all."""
    return hdf5.write_results(path, _head(result.spec, result.seed, result.version),
                              result.nominal, result.trials, _units(result.spec),
                              summary=lambda tr: _summary_json(result.spec, tr))


def trial_image(spec, seed: int, version: str, nominal: dict, trial) -> bytes:
    """One trial (:class:`~truthbench.campaign.results.TrialResult`) of a run of
    ``spec`` as the bytes of a results file holding it alone, with its summary
    (:func:`truthbench.io.hdf5.results_image`)."""
    return hdf5.results_image(_head(spec, seed, version), nominal, trial, _units(spec),
                              _summary_json(spec, trial))


def write_test_record(record, path: str | Path, *, spec, seed: int, trial: int,
                      injected=()) -> Path:
    """Write one test (time histories, FRFs, truth record) to HDF5, in the layout of a
    test group of a results file, with the campaign spec and what was injected."""
    from truthbench._version import __version__

    return hdf5.write_test_file(path, record, _head(spec, seed, __version__), trial=trial,
                                injected=injected)


# ---- the streaming store of a run: one file per finished trial, written atomically ----
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
        whose trials are read from their files when used
        (:class:`~truthbench.campaign.results.StoredTrials`); a partial store gives the
        trials it holds."""
        from truthbench.campaign.results import CampaignResult, StoredTrials
        from truthbench.campaign.spec import parse_campaign

        head = self.header()
        done = self.done()
        if not done:
            spec = parse_campaign(json.loads(head["spec_json"]), source=head.get("source"))
            return CampaignResult(spec, int(head["seed"]), head["truthbench_version"],
                                  spec.nominal_parameters(), (), path=str(self.dir))
        first = CampaignResult.load(self.trial_path(done[0]))
        entries = [(self.trial_path(t), hdf5.trial_key(t)) for t in done]
        return replace(first, trials=StoredTrials(first.spec, entries), path=str(self.dir),
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
                hdf5.limit_metadata_cache(out)  # memory flat in the number of trials
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
                    out.attrs.update({"format": hdf5.FORMAT, "seed": head["seed"],
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
