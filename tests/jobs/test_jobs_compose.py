"""docker-compose.yml describes the farm's topology (validated; no Docker engine here).

The same topology - one scheduler, single-threaded workers, a shared results folder -
runs for real without containers in test_jobs_distributed.py.
"""

import subprocess
from pathlib import Path

import yaml

ROOT = Path(__file__).parents[2]


def _config(docker_compose) -> dict:
    out = subprocess.run([docker_compose, "-f", str(ROOT / "docker-compose.yml"), "config"],
                         capture_output=True, text=True, cwd=ROOT, check=True)
    return yaml.safe_load(out.stdout)


def test_compose_file_is_valid_and_wires_the_farm(docker_compose):
    services = _config(docker_compose)["services"]
    assert {"scheduler", "worker", "client"} <= set(services)
    ports = {str(p.get("published", p.get("target"))) if isinstance(p, dict) else str(p)
             for p in services["scheduler"]["ports"]}
    assert any("8786" in p for p in ports) and any("8787" in p for p in ports)
    worker = services["worker"]["command"]
    assert worker[:3] == ["dask", "worker", "tcp://scheduler:8786"]
    assert worker[worker.index("--nthreads") + 1] == "1"  # one ccx per worker container
    results = {s: [v for v in services[s]["volumes"] if "/work/results" in str(v)]
               for s in ("scheduler", "worker", "client")}
    assert all(results.values()), "every service must share the results folder"


def test_dockerfile_installs_the_solver_and_the_package():
    text = (ROOT / "Dockerfile").read_text()
    assert "calculix-ccx" in text and "pip install" in text
    for folder in ("farm", "jobs", "storage", "analysis"):
        assert f"COPY {folder} {folder}" in text and (ROOT / folder / "__init__.py").exists()
