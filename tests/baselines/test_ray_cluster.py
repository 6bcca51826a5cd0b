"""The Ray backend on a real cluster: a head node and a worker node started with ``ray start`` on
the loopback interface (one CPU each), joined by the command line's ``--backend ray --address``.

The held-out suite built on the cluster equals the one built by the local backend (the same
scenarios, plans, rates and cache files, the solve times aside), the build ran as a job of that
cluster (not in a Ray of its own), and a map's tasks ran on both nodes. The cluster is stopped
after the module's tests, whatever they do: the two ``ray start --block`` processes are asked to
stop (each stops the Ray processes of its node), then whatever is left of their process groups
is killed; Ray processes of other clusters on the machine are not touched.

On Linux Ray turns a loopback address into the machine's network address for a cluster of
several nodes, and its single-node switch (``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, set for
every process here, the commands under test included) keeps the loopback address but refuses
a second node: the worker's ``ray start`` runs with that refusal lifted, and nothing else.

Ray is the optional ``ray`` extra: skipped without it, except under CI (``CI`` set), which
installs ``.[all]``.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import pytest

if os.environ.get("CI"):
    import ray  # noqa: F401  (CI installs the 'ray' extra: a missing Ray is a failure there)
else:
    pytest.importorskip("ray", reason="a Ray cluster needs the 'ray' extra")

ROOT = Path(__file__).resolve().parents[2]
LOOPBACK = "127.0.0.1"
START_TIMEOUT = 120.0  # s for both nodes to be up
RUN_TIMEOUT = 300.0  # s for one command against the cluster
#: ``ray start`` for a worker node on the loopback interface (see the module's docstring).
WORKER_START = textwrap.dedent("""
    import sys, types
    import ray._private.ray_constants as constants
    import ray.scripts.scripts as scripts
    scripts.ray_constants = types.SimpleNamespace(**{**vars(constants), "ENABLE_RAY_CLUSTER": True})
    sys.argv = ["ray", *sys.argv[1:]]
    sys.exit(scripts.main())
""")


class Cluster(NamedTuple):
    """A running cluster: its address and the environment its commands run with."""

    address: str
    env: dict[str, str]


def _free_ports(n: int) -> list[int]:
    sockets = [socket.socket() for _ in range(n)]
    try:
        for s in sockets:
            s.bind((LOOPBACK, 0))
        return [s.getsockname()[1] for s in sockets]
    finally:
        for s in sockets:
            s.close()


def _python(code: str, env: dict[str, str], timeout: float = RUN_TIMEOUT) -> str:
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)  # fmt: skip
    assert proc.returncode == 0, f"{code}\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    return proc.stdout


def _connected(address: str, body: str) -> str:
    """A script that joins the cluster at ``address`` (``ray`` and ``json`` imported), then runs ``body``."""
    return f"import json, ray\nray.init(address={address!r}, log_to_driver=False)\n{textwrap.dedent(body)}"


def _stop(node: subprocess.Popen) -> None:
    """Stop one ``ray start --block`` and every process of its group (its node's Ray processes)."""
    if node.poll() is None:
        node.send_signal(signal.SIGTERM)  # it drains its node and stops the node's processes
        try:
            node.wait(60)
        except subprocess.TimeoutExpired:
            pass
    try:
        os.killpg(node.pid, signal.SIGKILL)  # what is left of the group (none when it stopped cleanly)
    except ProcessLookupError:
        pass
    node.wait(10)


@pytest.fixture(scope="module")
def cluster() -> Iterator[Cluster]:
    # a short folder: the Unix sockets of Ray's processes live under it
    temp = Path(tempfile.mkdtemp(prefix="raycl-", dir="/tmp" if Path("/tmp").is_dir() else None))
    gcs, client, head_agent, worker_agent = _free_ports(4)
    address = f"{LOOPBACK}:{gcs}"
    env = {
        **os.environ,
        "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0",  # loopback addresses stay loopback
        "RAY_AUTH_MODE": "token",
        "RAY_AUTH_TOKEN": secrets.token_hex(32),  # this cluster's own token (~/.ray is not read)
        "RAY_USAGE_STATS_ENABLED": "0",
        "OMP_NUM_THREADS": "1",
    }
    node_options = ["--num-cpus", "1", "--object-store-memory", str(100 * 2**20), "--include-log-monitor",
                    "false", "--block"]  # fmt: skip
    ray_cli = [sys.executable, "-m", "ray.scripts.scripts"]
    nodes: list[subprocess.Popen] = []
    logs = []
    try:
        for name, argv in [
            ("head", [*ray_cli, "start", "--head", "--node-ip-address", LOOPBACK, "--port", str(gcs),
                      "--ray-client-server-port", str(client), "--dashboard-agent-listen-port",
                      str(head_agent), "--include-dashboard", "false", "--temp-dir", str(temp)]),
            ("worker", [sys.executable, "-c", WORKER_START, "start", "--address", address,
                        "--dashboard-agent-listen-port", str(worker_agent)]),
        ]:  # fmt: skip
            log = (temp / f"{name}.log").open("w")
            logs.append(log)
            nodes.append(subprocess.Popen([*argv, *node_options], cwd=temp, env=env, stdout=log,
                                          stderr=subprocess.STDOUT, start_new_session=True))  # fmt: skip
            deadline = time.monotonic() + START_TIMEOUT  # printed once the node is in the cluster
            while "Ray runtime started" not in (temp / f"{name}.log").read_text():
                assert nodes[-1].poll() is None, f"{name}: {(temp / f'{name}.log').read_text()[-4000:]}"
                assert time.monotonic() < deadline, f"{name} not up: {(temp / f'{name}.log').read_text()}"
                time.sleep(0.25)
        yield Cluster(address, env)
    finally:
        for node in reversed(nodes):  # the worker first, then the head
            _stop(node)
        for log in logs:
            log.close()
        shutil.rmtree(temp, ignore_errors=True)


def _untimed(value: Any) -> Any:
    """``value`` without its solve times (the ``seconds`` keys, at any depth)."""
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [_untimed(v) for v in value]
    return value


def _builds(tmp_path: Path, env: dict[str, str], runs: dict[str, list[str]]) -> dict[str, dict]:
    """``python -m agents.suite build`` of two scenarios with each run's options, all at the same
    time; by run, the suite file and the cache records (the solve times left out)."""
    procs = {}
    try:
        for name, options in runs.items():
            out = tmp_path / name
            argv = [sys.executable, "-m", "agents.suite", "build", "--n", "2", "--no-progress",
                    "--out", str(out / "suite.json"), "--cache", str(out / "cache"), *options]  # fmt: skip
            procs[name] = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                           stderr=subprocess.PIPE, text=True)  # fmt: skip
        built = {}
        for name, proc in procs.items():
            stdout, stderr = proc.communicate(timeout=RUN_TIMEOUT)
            assert proc.returncode == 0, f"{' '.join(proc.args)}\n{stdout[-2000:]}\n{stderr[-4000:]}"
            out = tmp_path / name
            records = {p.name: _untimed(json.loads(p.read_text())) for p in sorted((out / "cache").glob("*"))}
            built[name] = {"suite": json.loads((out / "suite.json").read_text()), "records": records}
        return built
    finally:
        for proc in procs.values():
            proc.kill()
            proc.wait()


def test_the_suite_built_on_the_cluster_equals_the_local_one(cluster, tmp_path):
    built = _builds(tmp_path, cluster.env, {
        "local": ["--jobs", "1"],
        "cluster": ["--jobs", "2", "--backend", "ray", "--address", cluster.address],
    })  # fmt: skip
    local, on_cluster = built["local"], built["cluster"]
    assert on_cluster["suite"]["build"]["backend"] == "ray" and "backend" not in local["suite"]["build"]
    assert len(local["records"]) == 2 and on_cluster["records"] == local["records"]
    assert _untimed(on_cluster["suite"]["scenarios"]) == _untimed(local["suite"]["scenarios"])
    # the build was a job of this cluster of two nodes, its driver on the loopback interface
    jobs, nodes = json.loads(_python(_connected(cluster.address, """
        jobs = [[j["Entrypoint"], j["DriverIPAddress"]] for j in ray._private.state.jobs()]
        print(json.dumps([jobs, [n["NodeManagerAddress"] for n in ray.nodes() if n["Alive"]]]))
    """), cluster.env).splitlines()[-1])  # fmt: skip
    builds = [ip for entry, ip in jobs if "agents.suite build" in entry and "--address" in entry]
    assert builds == [LOOPBACK] and nodes == [LOOPBACK, LOOPBACK], (jobs, nodes)


def test_a_map_runs_its_tasks_on_both_nodes(cluster, tmp_path):
    script = f"""
        import json, time
        import ray
        from baselines.runner import run_tasks

        def where(x):  # defined in __main__: Ray ships it to the workers by value
            time.sleep(1.0)  # the two tasks overlap: one on each node's CPU
            return {{"x": x, "node": ray.get_runtime_context().get_node_id()}}

        records = run_tasks(where, [1, 2], {str(tmp_path / "cache")!r}, key=str, jobs=2, backend="ray",
                            address={cluster.address!r}, progress=False)
        print(json.dumps([records, [n["NodeID"] for n in ray.nodes() if n["Alive"]]]))
    """
    records, nodes = json.loads(_python(textwrap.dedent(script), cluster.env).splitlines()[-1])
    assert [r["x"] for r in records] == [1, 2] and len(nodes) == 2
    assert {r["node"] for r in records} == set(nodes)
    assert {p.name for p in (tmp_path / "cache").glob("*.json")} == {"1.json", "2.json"}
