"""Running at scale: the streamed store, resume after SIGKILL, worker counts and Dask (a
LocalCluster, and a scheduler and workers started as users start them, one of them killed
mid-run), a failing disk, Ctrl-C, and the folder rules of ``truthbench run``."""

import errno
import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from truthbench.campaign.engines import make_engine
from truthbench.campaign.runner import run_to_store
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.store import StoreError, TrialStore
from truthbench.cli import main

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"
N_TRIALS = 8


def _small_text() -> str:
    """The quickstart with 2 s records (a trial takes a fraction of a second)."""
    text = (ROOT / "campaigns" / "quickstart.toml").read_text()
    text = text.replace("n_elements = 20", "n_elements = 8")
    text = text.replace("record_s = 64.0", "record_s = 2.0").replace("averages = 8",
                                                                     "averages = 2")
    assert tomllib.loads(text)["tests"][0]["record_s"] == 2.0
    return text


@pytest.fixture(scope="module")
def small_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("camp") / "small.toml"
    path.write_text(_small_text())
    return path


@pytest.fixture(scope="module")
def small_spec(small_file):
    return parse_campaign(tomllib.loads(small_file.read_text()), source=str(small_file))


def _reference(spec, out, n):
    """An uninterrupted run on one worker (in this process), gathered into results.h5."""
    summary = run_to_store(spec, out, trials=n)
    assert summary.complete and summary.ran == n and not summary.failed
    return TrialStore(out).consolidate()


@pytest.fixture(scope="module")
def reference(small_spec, tmp_path_factory):
    return _reference(small_spec, tmp_path_factory.mktemp("ref"), N_TRIALS)


def _datasets(path: Path) -> dict:
    """Every dataset (and group attribute) of a results file, bar the timings and when
    it was written."""
    out = {}

    def visit(name, obj):
        if "/seconds" in f"/{name}":
            return
        if isinstance(obj, h5py.Dataset):
            out[name] = obj[()]
        for k, v in obj.attrs.items():
            if k not in ("created_utc",):
                out[f"{name}@{k}"] = v

    with h5py.File(path, "r") as f:
        f.visititems(visit)
        out.update({f"@{k}": v for k, v in f.attrs.items() if k != "created_utc"})
    return out


def _assert_same(a: Path, b: Path) -> None:
    da, db = _datasets(a), _datasets(b)
    assert sorted(da) == sorted(db)
    different = [k for k in da if not np.array_equal(np.asarray(da[k]), np.asarray(db[k]),
                                                     equal_nan=np.asarray(da[k]).dtype.kind
                                                     in "fc")]
    assert not different, different[:10]


def _foreground_sigint():
    """SIGINT as at a terminal: a shell starts background jobs (``cmd &``) with SIGINT
    ignored, children inherit that, and Python then installs no KeyboardInterrupt
    handler, so the run would never see the test's Ctrl-C."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _run_cli(args, **kw):
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    return subprocess.Popen([sys.executable, "-m", "truthbench", "run", *map(str, args)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=_foreground_sigint, **kw)


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (Linux /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _wait_for(predicate, timeout_s: float, what: str):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        if predicate():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


# ---- worker counts and Dask -------------------------------------------------------------
def test_worker_counts_and_dask_give_bitwise_identical_stores(small_spec, tmp_path):
    """1 worker (the reference), 2 and 4 local processes and a Dask LocalCluster of two
    workers: the same datasets, bit for bit (every trial draws from its own seeds)."""
    n = 4
    reference = _reference(small_spec, tmp_path / "one", n)
    for jobs in (2, 4):
        out = tmp_path / f"jobs{jobs}"
        with make_engine(jobs) as engine:
            run_to_store(small_spec, out, trials=n, engine=engine)
        _assert_same(reference, TrialStore(out).consolidate())
        assert not (out / "trials").exists()
    pytest.importorskip("distributed", reason="dask.distributed is not installed (the "
                                              "'dask' extra)")
    out = tmp_path / "dask"
    with make_engine(2, "local") as engine:
        run_to_store(small_spec, out, trials=n, engine=engine)
    _assert_same(reference, TrialStore(out).consolidate())


def test_dask_batches_shrink_as_the_run_ends():
    """Up to four trials per task while there is much to do, one each at the end: every
    trial once, and the workers finish together (20 trials on two workers: not 12
    against 8)."""
    from truthbench.campaign.engines import batch_size

    for n, workers in ((20, 2), (7, 2), (1000, 3), (1, 4), (5, 1)):
        left, sizes = n, []
        while left:
            sizes.append(batch_size(left, workers, 4))
            left -= sizes[-1]
        assert sum(sizes) == n and max(sizes) <= 4 and min(sizes) >= 1
        assert sizes == sorted(sizes, reverse=True)
        assert sizes[-workers:] == [1] * min(workers, len(sizes))
    assert batch_size(0, 2, 4) == 0


# ---- a Dask cluster as users run one: scheduler and workers on loopback ---------------
def _dask(*args, log: Path) -> subprocess.Popen:
    """A ``dask`` command in its own process group, with this tree on the path; its
    output goes to ``log`` (read when a test fails)."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    return subprocess.Popen([sys.executable, "-m", "dask", *map(str, args)], env=env,
                            stdout=log.open("w"), stderr=subprocess.STDOUT,
                            start_new_session=True)


class Cluster:
    """A scheduler on a free loopback port and ``n`` single-threaded workers without
    nannies (a killed worker stays dead), ended with :meth:`close`."""

    def __init__(self, folder: Path, n: int = 2):
        self.folder = folder
        self.procs: list[subprocess.Popen] = []
        info = folder / "scheduler.json"
        self.scheduler = self._start("scheduler", "--host", "127.0.0.1", "--port", 0,
                                     "--no-dashboard", "--scheduler-file", info)
        _wait_for(lambda: info.exists() and info.stat().st_size > 0, 60,
                  f"the scheduler's address ({self._logs()})")
        self.address = json.loads(info.read_text())["address"]
        assert self.address.startswith("tcp://127.0.0.1:")
        self.workers = [self._start("worker", self.address, "--nthreads", 1,
                                    "--no-nanny", "--no-dashboard", "--host", "127.0.0.1",
                                    "--name", f"w{k}", log=f"worker{k}")
                        for k in range(n)]
        _wait_for(lambda: self.n_workers() == n, 90, f"{n} workers ({self._logs()})")

    def _start(self, what, *args, log=None) -> subprocess.Popen:
        proc = _dask(what, *args, log=self.folder / f"{log or what}.log")
        self.procs.append(proc)
        return proc

    def _logs(self) -> str:
        return "; ".join(f"{p.name}: {p.read_text()[-600:]}"
                         for p in sorted(self.folder.glob("*.log")))

    def n_workers(self) -> int:
        from distributed import Client

        with Client(self.address, timeout="10s") as client:
            return len(client.scheduler_info()["workers"])

    def busy(self, name: str) -> bool:
        """Whether the worker called ``name`` is running a task."""
        from distributed import Client

        with Client(self.address, timeout="10s") as client:
            workers = client.scheduler_info()["workers"]
            address = [a for a, w in workers.items() if w.get("name") == name]
            return bool(address and client.processing(address)[address[0]])

    def close(self) -> None:
        """End the workers, then the scheduler (a worker whose scheduler is gone would
        wait for it to come back)."""
        for p in reversed(self.procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
            try:
                p.wait(15)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(5)


@pytest.fixture()
def cluster(tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (the "
                                              "'dask' extra)")
    c = Cluster(tmp_path)
    try:
        yield c
    finally:
        c.close()
    assert not any(_alive(p.pid) for p in c.procs)


@pytest.mark.slow
def test_a_tcp_cluster_gives_the_local_store_bit_for_bit(cluster, small_file, reference,
                                                         tmp_path):
    out = tmp_path / "dask"
    assert main(["run", str(small_file), "--out", str(out), "--trials", str(N_TRIALS),
                 "--scheduler", cluster.address, "-q"]) == 0
    _assert_same(reference, out / "results.h5")
    assert cluster.n_workers() == 2  # the run leaves the cluster as it found it


@pytest.mark.slow
def test_a_worker_killed_mid_run_loses_and_repeats_no_trial(cluster, small_spec, small_file,
                                                            tmp_path):
    """SIGKILL one of the two workers once the run has stored a batch (up to four trials
    per task): the scheduler runs the lost worker's batch on the other, the run completes,
    every trial is stored once, and the results equal a local run's."""
    n = 6 * 4  # six batches: the killed worker is in the middle of one
    reference = _reference(small_spec, tmp_path / "local", n)
    out = tmp_path / "dask"
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    proc = subprocess.Popen([sys.executable, "-m", "truthbench", "run", str(small_file),
                             "--out", str(out), "--trials", str(n), "--scheduler",
                             cluster.address, "-v"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    store = TrialStore(out)
    try:
        _wait_for(lambda: len(store.done()) >= 1 or proc.poll() is not None, 120,
                  "the first stored trial")
        _wait_for(lambda: cluster.busy("w0") or proc.poll() is not None, 60,
                  "the first worker to run a batch")
        at_kill = len(store.done())
        os.killpg(cluster.workers[0].pid, signal.SIGKILL)
        _, err = proc.communicate(timeout=180)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err[-3000:]
    assert at_kill < n, "the run ended before the worker was killed"
    assert cluster.workers[0].wait(10) == -signal.SIGKILL
    stored = [int(line.split()[2]) for line in err.splitlines()
              if line.startswith("INFO: trial ") and "stored" in line]
    assert sorted(stored) == list(range(n))  # none lost, none twice
    _assert_same(reference, out / "results.h5")
    _wait_for(lambda: cluster.n_workers() == 1, 30, "the scheduler to drop the dead worker")


# ---- Ctrl-C, SIGKILL, then --resume ----------------------------------------------------
def test_interrupt_kill_and_resume_equal_an_uninterrupted_run(small_file, reference,
                                                              tmp_path):
    """Ctrl-C stops with one line and keeps the finished trials; a SIGKILL of the
    resumed run leaves its finished trials and no worker behind; a plain run then
    refuses to touch them; --resume completes the run, and the result equals an
    uninterrupted run dataset for dataset (no trial lost or repeated)."""
    out = tmp_path / "run"
    args = [small_file, "--out", out, "--trials", N_TRIALS, "--jobs", 2]
    store = TrialStore(out)
    proc = _run_cli([*args, "-q"])
    try:
        _wait_for(lambda: len(store.done()) >= 1, 120, "the first stored trial")
        workers = _children(proc.pid)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, (f"stderr {err!r}; stored {sorted(store.done())}; "
                                    f"results.h5 {(out / 'results.h5').exists()}")
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted:") and "--resume" in lines[0]
    after_int = set(store.done())
    assert f"{len(after_int)} of {N_TRIALS} trial(s) stored" in lines[0]
    assert after_int and len(after_int) < N_TRIALS
    _wait_for(lambda: not any(_alive(p) for p in workers), 20, "the workers to end")
    assert not list(store.dir.glob("*.part"))
    # resume, and kill the main process with SIGKILL once it stored another trial
    proc = _run_cli([*args, "-q", "--resume"])
    try:
        _wait_for(lambda: len(store.done()) > len(after_int), 120, "another stored trial")
        workers = _children(proc.pid)
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
    killed_with = set(store.done())
    assert killed_with > after_int and not (out / "results.h5").exists()
    assert workers
    _wait_for(lambda: not any(_alive(p) for p in workers), 20, "the workers to end")
    # a plain run refuses to touch the stored trials
    again = _run_cli([*args, "-q"])
    assert again.wait(60) == 2
    assert "--resume" in again.stderr.read()
    assert set(store.done()) == killed_with
    resumed = _run_cli([small_file, "--out", out, "--trials", N_TRIALS, "--jobs", 1,
                        "--resume", "-v"])  # any worker count: the same results
    _, err = resumed.communicate(timeout=300)
    assert resumed.returncode == 0, err
    ran_again = [int(line.split()[2]) for line in err.splitlines()
                 if line.startswith("INFO: trial ") and "stored" in line]
    assert sorted(ran_again) == sorted(set(range(N_TRIALS)) - killed_with)
    _assert_same(reference, out / "results.h5")
    assert (out / "report.html").exists() and not (out / "trials").exists()


# ---- a failing disk -----------------------------------------------------------------------
def test_full_disk_is_an_error_and_keeps_the_stored_trials(small_spec, reference, tmp_path,
                                                           monkeypatch, capsys):
    """The writer fails with ENOSPC at the third trial: a clear error naming the file
    and the trials kept; nothing already stored is lost, and --resume completes it."""
    import truthbench.campaign.store as store_mod

    real = store_mod.write_atomic
    calls = []

    def failing(path, data):
        calls.append(path)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, data)

    out = tmp_path / "run"
    monkeypatch.setattr(store_mod, "write_atomic", failing)
    with pytest.raises(StoreError, match=r"cannot store trial 1 \(no space left on device"
                                         r".*the 1 trial\(s\) already stored .* are kept"):
        run_to_store(small_spec, out, trials=N_TRIALS)  # run.json, trial 0, then trial 1
    store = TrialStore(out)
    assert store.done() == [0]
    assert not list(store.dir.glob("*.part"))
    # the same through the command line: exit 1, one message, the store kept
    calls.clear()
    camp = tmp_path / "small.toml"
    camp.write_text(_small_text())
    code = main(["run", str(camp), "--out", str(out), "--trials", str(N_TRIALS), "-q",
                 "--resume"])
    err = capsys.readouterr().err
    assert code == 1 and "cannot store trial 3 (no space left on device" in err
    assert "--resume" in err
    assert store.done() == [0, 1, 2]  # trials 1 and 2 stored, trial 3 failed
    monkeypatch.undo()
    assert main(["run", str(camp), "--out", str(out), "--trials", str(N_TRIALS), "-q",
                 "--resume"]) == 0
    _assert_same(reference, out / "results.h5")


def test_unwritable_output_folder_is_an_error_before_any_work(small_file, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["run", str(small_file), "--out", str(blocker / "sub"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "not writable" in err or "cannot start the results store" in err


# ---- folders, options, limits -----------------------------------------------------------
def test_existing_results_are_kept_unless_force(small_file, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(small_file), "--out", str(out), "--trials", "1", "-q"]) == 0
    stamp = (out / "results.h5").stat().st_mtime_ns
    assert main(["run", str(small_file), "--out", str(out), "--trials", "1", "-q"]) == 2
    err = capsys.readouterr().err
    assert "it is kept" in err and "--resume" in err and "--force" in err
    assert (out / "results.h5").stat().st_mtime_ns == stamp
    # --resume of a complete run: nothing to do
    assert main(["run", str(small_file), "--out", str(out), "--trials", "1", "--resume"]) == 0
    assert "nothing to resume" in capsys.readouterr().out
    # --force replaces every output of the earlier run
    (out / "frf_old_test.png").write_bytes(b"stale")
    assert main(["run", str(small_file), "--out", str(out), "--trials", "1", "-q",
                 "--force"]) == 0
    assert not (out / "frf_old_test.png").exists()


def test_resume_checks_the_stored_run(small_spec, small_file, tmp_path, capsys):
    out = tmp_path / "run"
    TrialStore(out).create(small_spec, small_spec.campaign.seed, 3, "x")
    assert main(["run", str(small_file), "--out", str(out), "--trials", "3", "--seed", "9",
                 "--resume"]) == 2
    err = capsys.readouterr().err
    assert "seed: stored 20261121, requested 9" in err


def test_jobs_are_capped_at_the_cores(small_file, tmp_path, capsys):
    from truthbench.campaign.engines import available_cores

    assert main(["run", str(small_file), "--out", str(tmp_path / "r"), "--trials", "1",
                 "--jobs", str(available_cores() + 62)]) == 0
    assert f"capped at the {available_cores()} core(s)" in capsys.readouterr().err


def test_sizes_that_cannot_fit_are_refused_before_any_work(small_file, tmp_path, capsys):
    out = tmp_path / "huge"
    assert main(["run", str(small_file), "--out", str(out), "--trials", "1000000000"]) == 2
    err = capsys.readouterr().err
    assert "1000000000 trials x" in err and "MB" in err
    assert not (out / "trials").exists()


def test_report_of_a_partial_store_says_how_many_trials(small_spec, tmp_path, capsys):
    from truthbench.campaign.engines import trial_job
    from truthbench.campaign.plan import CampaignPlan

    out = tmp_path / "run"
    store = TrialStore(out)
    store.create(small_spec, small_spec.campaign.seed, 5, "x")
    for t in (0, 2):
        _, image, _ = trial_job(CampaignPlan.compile(small_spec), t, small_spec.campaign.seed)
        store.write(t, image)
    (store.dir / "000003.h5.part").write_bytes(b"half a trial")
    assert main(["report", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "partial store: 2 of 5 trial(s)" in printed
    assert (out / "report.html").exists()
    from truthbench.campaign.results import CampaignResult

    assert [t.trial for t in CampaignResult.load(out).trials] == [0, 2]
