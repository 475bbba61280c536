"""Batches of configurations and runs on Dask distributed (pipeline.batch, pipeline.cluster):
the same files as ``--jobs`` (JSON, OBJ and CSV byte for byte; DXF and PDF carry their
creation time), each configuration of a batch in DIR/<stem>/, bad input refused before
anything is written. The cluster is a LocalCluster of two worker processes."""

from __future__ import annotations

import json
import os
import pickle
import signal
import socket
from pathlib import Path

import pytest
import yaml

from pipeline.cli import main

distributed = pytest.importorskip("distributed")  # the test extra installs it

ROOT = Path(__file__).resolve().parents[1]
STRAKE = ROOT / "configs" / "hullmod_strake.yaml"
SAME_BYTES = (".json", ".obj", ".csv")


@pytest.fixture(scope="module", autouse=True)
def no_child_left():
    """After this module the test process has no child: every cluster's workers are gone,
    and so is the resource tracker that multiprocessing starts for the first spawned
    process and keeps for the interpreter's life (tests after this module, e.g.
    test_renderproc, check that a run leaves no child)."""
    from multiprocessing import resource_tracker

    tracker = resource_tracker._resource_tracker  # no public way to stop it
    running = getattr(tracker, "_pid", None) is not None
    yield
    if not running and getattr(tracker, "_pid", None) is not None:
        tracker._stop()
        with pytest.raises(ChildProcessError):
            os.waitpid(-1, os.WNOHANG)


@pytest.fixture(scope="module")
def cluster():
    """A LocalCluster of two worker processes and a client to look at it; yields
    (address, client)."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc:
        with distributed.Client(lc, set_as_default=False) as client:
            yield lc.scheduler_address, client


def executed(client) -> int:
    """Tasks the cluster's workers have run so far."""
    return sum(client.run(lambda dask_worker: dask_worker.state.executed_count).values())


def files(folder: Path) -> dict[str, Path]:
    return {str(p.relative_to(folder)): p for p in sorted(folder.rglob("*")) if p.is_file()}


def assert_same_outputs(expected: Path, got: Path) -> None:
    """The same file names; the JSON, OBJ and CSV files byte for byte."""
    want, have = files(expected), files(got)
    assert sorted(have) == sorted(want)
    compared = [name for name in want if name.endswith(SAME_BYTES)]
    assert {Path(n).suffix for n in compared} == set(SAME_BYTES)
    for name in compared:
        assert have[name].read_bytes() == want[name].read_bytes(), name


def small_strake(tmp_path: Path, name: str, butts: int = 3) -> Path:
    """hullmod_strake.yaml cut to fewer butts (2 x (butts - 1) plates), saved as NAME.yaml."""
    data = yaml.safe_load(STRAKE.read_text())
    data["strake"]["surface"]["iges"] = str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")
    data["strake"]["butts"] = data["strake"]["butts"][:butts]
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_part_result_survives_pickling(tmp_path):
    """What a worker sends back: a part's whole result, as --jobs 1 exports it."""
    from pipeline.hull.plates import evaluate_plate
    from pipeline.runner import guarded_export, guarded_run
    from pipeline.validate import validate

    config = validate(small_strake(tmp_path, "one", butts=2), evaluate_plate)
    result = guarded_run(config.parts[0], config)
    assert result.ok
    copy = pickle.loads(pickle.dumps(result))
    guarded_export(result, config, tmp_path / "a", tmp_path)
    guarded_export(copy, config, tmp_path / "b", tmp_path)
    for name in ("hullmod_S1_B1.json", "hullmod_S1_B1.obj"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_a_strake_on_the_cluster_writes_what_jobs_1_and_2_write(cluster, tmp_path):
    address, client = cluster
    assert main(["run", str(STRAKE), "--out", str(tmp_path / "j1"), "--quiet"]) == 0
    assert main(["run", str(STRAKE), "--out", str(tmp_path / "j2"), "--quiet", "--jobs", "2"]) == 0
    before = executed(client)
    assert main(["run", str(STRAKE), "--out", str(tmp_path / "dask"), "--quiet", "--scheduler", address]) == 0
    summary = json.loads((tmp_path / "dask" / "hullmod_summary.json").read_text())
    assert len(summary["parts"]) == 10 and summary["failed"] == []
    assert executed(client) - before >= 10  # the plates ran on the workers
    assert_same_outputs(tmp_path / "j1", tmp_path / "j2")
    assert_same_outputs(tmp_path / "j1", tmp_path / "dask")
    assert [p.name for p in (tmp_path / "dask").iterdir() if p.name.startswith(".")] == []  # no staging, no lock


def test_a_batch_writes_each_config_into_its_own_folder(cluster, tmp_path, capsys):
    """Two configurations in one command: DIR/<stem>/ each, what each run alone writes, on
    the cluster and with --jobs alike."""
    address, _ = cluster
    strake = small_strake(tmp_path, "two_plates")  # 4 plates
    plate = ROOT / "configs" / "plate.yaml"
    for config in (strake, plate):
        assert main(["run", str(config), "--out", str(tmp_path / "alone" / config.stem), "--quiet"]) == 0
    assert main(["run", str(strake), str(plate), "--out", str(tmp_path / "jobs"), "--jobs", "2"]) == 0
    printed = capsys.readouterr().out
    assert f"{strake}:" in printed and f"{plate}:" in printed
    for config in (strake, plate):  # each folder's line counts what a run of that config alone writes
        alone = sum(1 for f in (tmp_path / "alone" / config.stem).rglob("*") if f.is_file())
        assert f"wrote {alone} files to {tmp_path / 'jobs' / config.stem}/" in printed
    assert main(["run", str(strake), str(plate), "--out", str(tmp_path / "dask"), "--quiet",
                 "--scheduler", address]) == 0
    for out in ("jobs", "dask"):
        assert sorted(p.name for p in (tmp_path / out).iterdir()) == ["plate", "two_plates"]
        assert_same_outputs(tmp_path / "alone", tmp_path / out)


def test_a_batchs_adaptive_plans_are_evaluated_on_the_cluster(cluster, tmp_path, monkeypatch):
    """Two adaptive plans of the cylinder-sphere strake under other names (no objective;
    flat + strip with 3 x the weld) in one batch on the cluster: their candidate plates are
    evaluated by the cluster's workers, not by this process, each plate once for both plans
    (and the splits of those that do not fit are chosen there),
    and each configuration's files are the bytes its run alone with --jobs 1 writes."""
    from pipeline import clusterplan
    from tests.test_plan_objective import _cs

    address, client = cluster
    configs = [_cs(tmp_path, "csa", "adaptive", None, max_splits=2),
               _cs(tmp_path, "csb", "adaptive", {"maximise": "flat_strip", "weld_factor": 3.0}, max_splits=2)]
    for config in configs:
        assert main(["run", str(config), "--out", str(tmp_path / "alone" / config.stem), "--quiet"]) == 0
    used = []
    make = clusterplan.ClusterEvaluator
    monkeypatch.setattr(clusterplan, "ClusterEvaluator", lambda c: used.append(make(c)) or used[-1])
    before = executed(client)
    assert main(["run", *map(str, configs), "--out", str(tmp_path / "dask"), "--quiet", "--scheduler", address]) == 0
    (evaluator,) = used
    assert evaluator.computed > 10 and evaluator.requested > evaluator.computed  # csb reuses csa's plates
    assert evaluator.cpu_seconds > 0.0 and evaluator.local_cpu_seconds == 0.0  # none evaluated here
    assert evaluator.mapped_cpu_seconds > 0.0  # csa's splits chosen there too
    plates = sum(len(json.loads((tmp_path / "dask" / c.stem / f"{c.stem}_summary.json").read_text())["parts"])
                 for c in configs)
    assert executed(client) - before >= evaluator.computed + plates  # the candidates, then the plates
    assert_same_outputs(tmp_path / "alone", tmp_path / "dask")


def test_a_local_cluster_of_two_processes_is_started_and_stopped(tmp_path):
    psutil = pytest.importorskip("psutil")
    configs = [str(ROOT / "configs" / name) for name in ("frustum.yaml", "flat_plate.yaml", "plate.yaml")]
    assert main(["run", *configs, "--out", str(tmp_path / "jobs"), "--quiet"]) == 0
    before = {p.pid for p in psutil.Process().children(recursive=True)}
    assert main(["run", *configs, "--out", str(tmp_path / "local"), "--quiet", "--scheduler", "local:2"]) == 0
    assert_same_outputs(tmp_path / "jobs", tmp_path / "local")
    after = [p for p in psutil.Process().children(recursive=True) if p.pid not in before]
    # its worker processes are gone (multiprocessing's resource tracker stays, one per interpreter)
    assert [p.cmdline() for p in after if "resource_tracker" not in " ".join(p.cmdline())] == []


def test_textile_pieces_come_back_whole_and_are_laid_out_by_the_coordinator(cluster, tmp_path):
    """A textile run sends back each piece's whole result (pieces are laid out side by side
    before any is written): the same files as --jobs 1."""
    address, _ = cluster
    configs = [str(ROOT / "configs" / name) for name in ("lampshade.yaml", "sail.yaml")]
    assert main(["run", *configs, "--out", str(tmp_path / "jobs"), "--quiet"]) == 0
    assert main(["run", *configs, "--out", str(tmp_path / "dask"), "--quiet", "--scheduler", address]) == 0
    assert_same_outputs(tmp_path / "jobs", tmp_path / "dask")
    assert (tmp_path / "dask" / "lampshade" / "lampshade.dxf").exists()  # the marker of the run


def test_a_geometric_failure_on_the_cluster_exits_1_with_its_report(cluster, tmp_path):
    address, _ = cluster
    configs = [str(ROOT / "configs" / name) for name in ("c_against_mirror.yaml", "frustum.yaml")]
    assert main(["run", *configs, "--out", str(tmp_path / "jobs"), "--quiet"]) == 1
    assert main(["run", *configs, "--out", str(tmp_path / "dask"), "--quiet", "--scheduler", address]) == 1
    assert_same_outputs(tmp_path / "jobs", tmp_path / "dask")
    assert not list((tmp_path / "dask" / "c_against_mirror").glob("*.dxf"))


def test_a_bad_config_among_several_exits_2_naming_it_and_writes_nothing(cluster, tmp_path, capsys):
    address, _ = cluster
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nunits: mm\n")
    good = ROOT / "configs" / "frustum.yaml"
    for extra in ([], ["--scheduler", address]):
        out = tmp_path / "out"
        assert main(["run", str(good), str(bad), "--out", str(out), "--quiet", *extra]) == 2
        err = capsys.readouterr().err
        assert str(bad) in err and "Traceback" not in err
        assert not out.exists()
    other = tmp_path / "other"
    other.mkdir()
    (other / "frustum.yaml").write_text(good.read_text())
    assert main(["run", str(good), str(other / "frustum.yaml"), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "would both write into" in err and str(tmp_path / "out" / "frustum") in err
    assert not (tmp_path / "out").exists()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_scheduler_exits_2_and_writes_nothing(tmp_path, capsys):
    address = f"tcp://127.0.0.1:{free_port()}"
    out = tmp_path / "out"
    code = main(["run", str(ROOT / "configs" / "frustum.yaml"), "--out", str(out), "--quiet",
                 "--scheduler", address, "--scheduler-timeout", "1"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(f"devflat: error: --scheduler {address}: no Dask scheduler with a worker answered within 1 s")
    assert "Traceback" not in err and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize("spec", ["localhost:8786", "local:0", "local:65", "local:x", "tcp://host", "http://h:8786",
                                  "tcp://h:70000"])
def test_a_bad_scheduler_spec_exits_2_before_anything_runs(tmp_path, capsys, spec):
    out = tmp_path / "out"
    assert main(["run", str(ROOT / "configs" / "frustum.yaml"), "--out", str(out), "--scheduler", spec]) == 2
    assert f"--scheduler {spec}: give " in capsys.readouterr().err
    assert not out.exists()


def test_jobs_and_a_scheduler_are_refused_together(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(ROOT / "configs" / "frustum.yaml"), "--out", str(out), "--jobs", "2",
                 "--scheduler", "local:2"]) == 2
    assert "--jobs 2 --scheduler local:2: the scheduler's workers run the parts" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGKILL])
def test_an_interrupted_cluster_run_leaves_no_worker_and_no_partial_output(tmp_path, signum):
    """Ctrl-C reaches the whole process group: the local cluster's workers ignore it, the
    run stops them, removes its staging folder and says so in one line. Killed, the run's
    workers die with it and the next run clears what it left."""
    from pipeline.outdir import LOCK_NAME, STAGING_PREFIX
    from tests.test_run_faults import alive, children, devflat, staged_part, strake_config, wait_for

    out = tmp_path / "out"
    config = strake_config(tmp_path, butts=range(56000, 104001, 4000))  # 24 plates
    run = devflat("run", str(config), "--out", str(out), "--quiet", "--scheduler", "local:2",
                  start_new_session=True)
    wait_for(lambda: staged_part(out) or run.poll() is not None)
    assert run.poll() is None, run.communicate()
    workers = [p for p in children(run.pid) for p in [p, *children(p)]]
    assert len(workers) >= 2
    if signum == signal.SIGINT:
        os.killpg(run.pid, signum)
    else:
        os.kill(run.pid, signum)
    _, err = run.communicate(timeout=60)
    wait_for(lambda: not any(alive(w) for w in workers), timeout=30)
    if signum == signal.SIGINT:
        assert run.returncode == 130
        assert err.strip().splitlines() == ["devflat: interrupted (SIGINT)"]
        assert not out.exists()
        return
    assert run.returncode == -signal.SIGKILL
    assert {p.name for p in out.iterdir()} <= {LOCK_NAME} | {p.name for p in out.glob(STAGING_PREFIX + "*")}
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    assert not list(out.glob(STAGING_PREFIX + "*"))


class KillOnePart(distributed.WorkerPlugin):
    """A worker plugin (installed on every worker, restarted ones too) that makes the
    worker process die when it computes the part ``name``."""

    def __init__(self, name: str):
        self.name = name

    def setup(self, worker) -> None:
        import pipeline.hull.plates as plates

        run_part, name = plates.run_part, self.name

        def dying(part, config):
            if part.name == name:
                os._exit(3)
            return run_part(part, config)

        plates.run_part = dying


def test_a_part_that_kills_its_workers_fails_alone(tmp_path, monkeypatch):
    """The part fails alone, and the dead workers' temporary folders go with the cluster
    (a worker wrote its part in a folder of the system's temporary directory, left behind
    by every worker that died on it)."""
    import dask

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))  # the cluster's workers and their scratch space
    monkeypatch.setattr("tempfile.tempdir", None)
    plugin = KillOnePart("two_plates_S1_B2")
    config = small_strake(tmp_path, "two_plates")
    data = yaml.safe_load(config.read_text())
    data["name"] = "two_plates"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "jobs"), "--quiet"]) == 0
    with dask.config.set({"distributed.scheduler.allowed-failures": 1}):  # one retry on another worker
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=":0") as lc:
            with distributed.Client(lc, set_as_default=False) as client:
                client.register_plugin(plugin)
                code = main(["run", str(config), "--out", str(tmp_path / "dask"), "--quiet",
                             "--scheduler", lc.scheduler_address])
    assert code == 1
    summary = json.loads((tmp_path / "dask" / "two_plates_summary.json").read_text())
    assert [row["id"] for row in summary["parts"]] == [f"two_plates_S{s}_B{b}" for s in (1, 2) for b in (1, 2)]
    assert summary["failed"] == ["two_plates_S1_B2"]
    report = json.loads((tmp_path / "dask" / "two_plates_S1_B2.json").read_text())
    assert "its worker process died" in report["reason"]
    assert not (tmp_path / "dask" / "two_plates_S1_B2.dxf").exists()
    for name in ("two_plates_S1_B1", "two_plates_S2_B1", "two_plates_S2_B2"):
        for suffix in (".json", ".obj"):
            assert (tmp_path / "dask" / f"{name}{suffix}").read_bytes() == \
                (tmp_path / "jobs" / f"{name}{suffix}").read_bytes()
    assert not [p for p in scratch.rglob("devflat-part-*")]
