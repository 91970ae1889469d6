"""The container image and the compose cluster, checked without a container engine.

The end-to-end test is ``scripts/test-cluster.sh`` (run by CI's ``.ci/run``): it builds the
image with podman, starts docker-compose.yml's scheduler and two workers, runs
examples/compose_quick.toml from the client container, checks the shared store and the
dashboard, and tears down. These tests keep the files honest where no engine is: the
compose file as Debian's ``docker-compose`` (v1) resolves it, the Dockerfile, the
.dockerignore and the study the script submits. The same topology also runs for real,
without containers, in test_jobs_distributed.py.
"""

from __future__ import annotations

import fnmatch
import os
import re
import subprocess
import tomllib
from pathlib import Path

import pytest
import yaml

from jobs.study import load_study

ROOT = Path(__file__).parents[2]
DOCKERFILE = (ROOT / "Dockerfile").read_text()
SCRIPT = (ROOT / "scripts" / "test-cluster.sh").read_text()
STUDY = ROOT / "examples" / "compose_quick.toml"
PACKAGES = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
    "packages"]["find"]["include"]
UNITS = {"": 1, "b": 1, "k": 2**10, "kb": 2**10, "kib": 2**10, "m": 2**20, "mb": 2**20,
         "mib": 2**20, "g": 2**30, "gb": 2**30, "gib": 2**30}


def _config(docker_compose, **env) -> dict:
    """``docker-compose config``: the file as an engine reads it, ``FARM_*`` knobs given."""
    clean = {k: v for k, v in os.environ.items() if not k.startswith("FARM_")}
    out = subprocess.run([docker_compose, "-f", str(ROOT / "docker-compose.yml"), "config"],
                         capture_output=True, text=True, cwd=ROOT, check=True,
                         env={**clean, **env})
    return yaml.safe_load(out.stdout)["services"]


@pytest.fixture(scope="module")
def services(docker_compose) -> dict:
    return _config(docker_compose)


def _published(service: dict) -> dict[int, tuple[str, int]]:
    """{container port: (host address, host port)} from short or long port syntax."""
    ports = {}
    for p in service.get("ports", []):
        if isinstance(p, dict):
            ports[int(p["target"])] = (p.get("host_ip", ""), int(p["published"]))
        else:
            *host, target = str(p).split("/")[0].split(":")
            ports[int(target)] = (host[0] if len(host) == 2 else "", int(host[-1]))
    return ports


def _bytes(size: str) -> int:
    number, unit = re.fullmatch(r"([\d.]+)\s*([a-zA-Z]*)", str(size)).groups()
    return int(float(number) * UNITS[unit.lower()])


def _option(command: list[str], name: str) -> str:
    return command[command.index(name) + 1]


def test_compose_wires_one_scheduler_single_threaded_workers_and_a_client(services):
    assert {"scheduler", "worker", "client"} <= set(services)
    worker = services["worker"]["command"]
    assert worker[:3] == ["dask", "worker", "tcp://scheduler:8786"]
    assert _option(worker, "--nthreads") == "1"  # one ccx per worker container
    assert services["worker"]["deploy"]["replicas"] == 2  # podman-compose 1.0 ignores --scale
    assert "client" in services["client"]["profiles"]
    for name in ("worker", "client"):
        assert "scheduler" in services[name]["depends_on"]


def test_ports_are_published_on_the_loopback_only_by_default(services):
    # Dask runs code on the workers for whoever reaches the scheduler: never on 0.0.0.0
    # by default (the old file published 8786/8787 on every interface, unauthenticated).
    ports = _published(services["scheduler"])
    assert ports == {8786: ("127.0.0.1", 8786), 8787: ("127.0.0.1", 8787)}
    for name in ("worker", "client"):
        assert not services[name].get("ports"), f"{name} publishes ports"


def test_address_and_host_ports_are_settable(docker_compose):
    open_ = _config(docker_compose, FARM_BIND_ADDRESS="0.0.0.0", FARM_SCHEDULER_PORT="18786",
                    FARM_DASHBOARD_PORT="18787")
    assert _published(open_["scheduler"]) == {8786: ("0.0.0.0", 18786),
                                              8787: ("0.0.0.0", 18787)}


def test_healthchecks_probe_the_dashboard_port_each_service_serves(services):
    for name in ("scheduler", "worker"):
        port = _option(services[name]["command"], "--dashboard-address").rsplit(":", 1)[1]
        test = services[name]["healthcheck"]["test"]
        # a string (run by the shell): podman-compose 1.0 pops the first item of a list
        # form once per replica, which breaks the second worker
        assert isinstance(test, str), test
        assert f"http://127.0.0.1:{port}/health" in test
        assert "curl" not in test and "wget" not in test  # neither is in the image


def test_workers_memory_is_bounded_with_the_dask_limit_below_the_container_limit(services):
    worker = services["worker"]
    container = _bytes(worker["mem_limit"])
    dask = _bytes(_option(worker["command"], "--memory-limit"))
    assert 0 < dask < container  # the nanny restarts a worker before the OOM killer acts
    assert container - dask >= 2**29  # room for ccx, a child the nanny does not count


def test_no_service_runs_as_root(services):
    for name, service in services.items():
        uid = str(service.get("user", "")).split(":")[0]
        assert uid and uid not in ("0", "root"), f"{name} runs as {uid or 'the image user'}"
    users = re.findall(r"^USER\s+(\S+)", DOCKERFILE, flags=re.M)
    assert users and users[-1] not in ("root", "0")
    assert re.search(r"useradd[^\n]*--uid 1000[^\n]*farm", DOCKERFILE)


def test_every_service_shares_one_working_folder_at_the_same_path(services, tmp_path,
                                                                  monkeypatch):
    mounts = {}
    for name in ("scheduler", "worker", "client"):
        service = services[name]
        work = [v for v in service["volumes"] if str(v).split(":")[1] == "/work"]
        assert len(work) == 1, f"{name} lacks the shared /work mount"
        assert service["working_dir"] == "/work"
        mounts[name] = work[0].split(":")[0]
    assert len(set(mounts.values())) == 1, mounts  # the same host folder everywhere
    # the study's store resolves inside /work, so it is the same path in every container
    monkeypatch.chdir(tmp_path)
    store = Path(load_study(STUDY).store)
    assert store.is_relative_to(tmp_path / "results")


def test_dockerfile_copies_every_package_of_the_project():
    for pattern in PACKAGES:
        package = pattern.rstrip("*")
        assert (ROOT / package / "__init__.py").exists()
        assert re.search(rf"^COPY {package} {package}$", DOCKERFILE, flags=re.M), package
    assert re.search(r"^COPY examples examples$", DOCKERFILE, flags=re.M)


def test_dockerfile_installs_python_from_debian_and_the_cluster_extras():
    assert re.search(r"^FROM debian:bookworm-slim$", DOCKERFILE, flags=re.M)
    for package in ("python3-venv", "calculix-ccx", "libglu1-mesa"):
        assert package in DOCKERFILE
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert "s3" in extras and re.search(r'^ARG FARM_EXTRAS="[^"]*\bs3\b', DOCKERFILE, re.M)
    assert "rm -rf /var/lib/apt/lists" in DOCKERFILE and "PIP_NO_CACHE_DIR=1" in DOCKERFILE


def test_dockerfile_checks_the_solver_with_a_command_that_can_succeed():
    # Debian's ccx 2.20 exits 201 on `ccx -v`: the old image could never build
    instructions = "\n".join(line for line in DOCKERFILE.splitlines()
                             if not line.lstrip().startswith("#"))
    assert not re.search(r"ccx -v\b", instructions)
    assert "ccx -i" in instructions and "farm --help" in instructions


def _ignored(name: str, patterns: list[str]) -> bool:
    return any(fnmatch.fnmatch(name, p.removeprefix("**/")) for p in patterns)


def test_dockerignore_keeps_the_venv_out_and_everything_copied_in():
    patterns = [line.strip() for line in (ROOT / ".dockerignore").read_text().splitlines()
                if line.strip() and not line.startswith("#")]
    for heavy in (".venv", ".git", "results", "reproduction", "x.zarr", "__pycache__", "work"):
        assert _ignored(heavy, patterns), heavy
    copied = [src for line in re.findall(r"^COPY (.+)$", DOCKERFILE, flags=re.M)
              for src in line.split()[:-1]]
    assert copied
    for src in copied:
        assert (ROOT / src).exists(), src
        assert not _ignored(src, patterns), f"{src} is copied but .dockerignore drops it"


def test_the_end_to_end_script_submits_a_small_study_and_expects_all_of_it():
    study = load_study(STUDY)
    experiments = len(study.deflections) * len(study.pressures)
    assert experiments <= 8  # quick: CI runs it on 2 cores
    assert f'study="{STUDY.relative_to(ROOT)}"' in SCRIPT
    assert re.search(rf"^expected={experiments}\b", SCRIPT, flags=re.M)
    assert "trap finish EXIT" in SCRIPT and "compose down" in SCRIPT
