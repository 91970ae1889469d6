#!/usr/bin/env bash
# End-to-end test of the container image and the compose cluster (run by CI after the unit
# tests): build the image, start the project's own docker-compose.yml (scheduler + 2
# workers), submit examples/compose_quick.toml from the client container, check every
# experiment is done in the shared store, read the dashboard, tear down (also on failure).
# Prints the time each phase took; exits non-zero on any failure. Run as root (podman).
#
#   bash scripts/test-cluster.sh            # FARM_WORKERS=3 for more workers
#   KEEP_WORK=1 bash scripts/test-cluster.sh  # keep the working folder (the store) afterwards
#
# podman-compose 1.0 (Debian bookworm's) ignores --scale, profiles and depends_on
# conditions, does not pass a container's exit code on, and runs no healthchecks without
# systemd: hence deploy.replicas (FARM_WORKERS), explicit services on `up`, `podman wait`
# for exit codes and `podman healthcheck run` below.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

project="${FARM_COMPOSE_PROJECT:-tyre-farm-test}"
study="examples/compose_quick.toml"
expected=4  # experiments in $study
export FARM_WORKERS="${FARM_WORKERS:-2}"
work="$(mktemp -d "${TMPDIR:-/tmp}/tyre-farm-cluster.XXXXXX")"
logs="$work/logs"
mkdir -p "$logs"
export FARM_WORK_DIR="$work"

# --- timing and clean-up -----------------------------------------------------------------
source "$root/scripts/phases.sh"
fail() { echo "test-cluster: FAILED: $*" >&2; exit 1; }
compose() { podman-compose -p "$project" "$@" >>"$logs/compose.log" 2>&1; }

finish() {
    local rc=$?
    trap - EXIT
    set +e
    if [ "$rc" -ne 0 ] && [ -s "$logs/compose.log" ]; then
        echo "--- errors in $logs/compose.log" >&2
        grep -i "error" "$logs/compose.log" | grep -v -e systemd -e "no such container" | tail -5 >&2
    fi
    if [ "$rc" -ne 0 ] && command -v podman >/dev/null; then
        for c in $(podman ps -a --format '{{.Names}}' \
                     --filter "label=io.podman.compose.project=$project" 2>/dev/null); do
            echo "--- logs of $c (last 30 lines)" >&2
            podman logs --tail 30 "$c" >&2 2>&1
        done
    fi
    phase teardown
    if command -v podman-compose >/dev/null; then
        compose down
        podman network rm -f "${project}_default" >/dev/null 2>&1
    fi
    print_timings
    printf '   %-10s %4d s\n' total "$SECONDS" >&2
    if [ "$rc" -ne 0 ] || [ -n "${KEEP_WORK:-}" ]; then
        echo "working folder kept (store, logs): $work" >&2
    else
        rm -rf "$work"
    fi
    [ "$rc" -eq 0 ] && echo "test-cluster: OK" >&2 || echo "test-cluster: FAILED (rc $rc)" >&2
    exit "$rc"
}
trap finish EXIT

# One-off client command through the compose file's client service; its exit code.
client() {
    local name="${project}_client_$RANDOM"
    compose run -d -T --no-deps --name "$name" client "$@"
    podman container exists "$name" || fail "client container did not start (see $logs/compose.log)"
    podman logs -f "$name" || true
    local rc
    rc="$(podman wait "$name")"
    podman rm -f "$name" >/dev/null
    return "$rc"
}

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

# --- 1. engine -----------------------------------------------------------------------------
phase engine
if ! command -v podman >/dev/null || ! command -v podman-compose >/dev/null \
   || ! podman image exists docker.io/library/debian:bookworm-slim; then
    [ "$(id -u)" -eq 0 ] || fail "podman is missing: run as root to install it (scripts/container-engine.sh)"
    bash scripts/container-engine.sh
fi

# --- 2. image ------------------------------------------------------------------------------
phase build
podman build --network host -t tyre-farm:latest . >"$logs/build.log" 2>&1 \
    || { tail -40 "$logs/build.log" >&2; fail "podman build (log: $logs/build.log)"; }
podman images --format 'image: {{.Repository}}:{{.Tag}} {{.ID}} {{.Size}}' tyre-farm:latest >&2

# --- 3. cluster ----------------------------------------------------------------------------
phase up
# The containers run as uid 1000; the working folder must be theirs. Free host ports, so
# that a Dask already listening on 8786/8787 here does not break the test.
if [ "$(id -u)" -eq 0 ]; then chown 1000:1000 "$work"; else
    export FARM_UID="$(id -u)" FARM_GID="$(id -g)"; fi
export FARM_SCHEDULER_PORT="${FARM_SCHEDULER_PORT:-$(free_port)}"
export FARM_DASHBOARD_PORT="${FARM_DASHBOARD_PORT:-$(free_port)}"
compose down  # leftovers of an interrupted run under the same project name
compose up -d scheduler worker
containers=("${project}_scheduler_1")
for i in $(seq 1 "$FARM_WORKERS"); do containers+=("${project}_worker_$i"); done

phase health
deadline=$((SECONDS + 180))
for c in "${containers[@]}"; do
    until podman healthcheck run "$c" >/dev/null 2>&1; do
        [ "$(podman inspect -f '{{.State.Running}}' "$c" 2>/dev/null)" = true ] \
            || fail "$c is not running"
        [ "$SECONDS" -lt "$deadline" ] || fail "$c not healthy after 180 s"
        sleep 2
    done
    echo "   $c healthy" >&2
done
# Published on the loopback only (docker-compose.yml), and nobody runs as root.
for port in 8786 8787; do
    bound="$(podman port "${project}_scheduler_1" "$port/tcp")"
    [[ "$bound" == 127.0.0.1:* ]] || fail "scheduler port $port published on $bound, not 127.0.0.1"
done
for c in "${containers[@]}"; do
    [ "$(podman exec "$c" id -u)" != 0 ] || fail "$c runs as root"
done

# --- 4. the sweep --------------------------------------------------------------------------
phase submit
client farm sweep submit "$study" --scheduler tcp://scheduler:8786 --workers "$FARM_WORKERS" \
    || fail "farm sweep submit exited non-zero"

phase check
# Read the shared store from the client container and write the counts to /work (outside
# results/): the host must see both - the store and the file - in its working folder.
client python -c "
import json, sys
import storage
from jobs.study import load_study
study = load_study(sys.argv[1])
counts = storage.status_counts(study.store, study.group_name)
json.dump({'store': study.store, 'counts': counts}, open('cluster-status.json', 'w'))
print('store', study.store, counts)
" "$study" || fail "reading the store in the client container"
python3 - "$work" "$expected" <<'PY' || fail "the store does not hold every experiment as done"
import json, pathlib, sys
work, expected = pathlib.Path(sys.argv[1]), int(sys.argv[2])
status = json.loads((work / "cluster-status.json").read_text())
counts = status["counts"]
assert counts.get("done") == expected and sum(counts.values()) == expected, counts
store = work / "results" / pathlib.Path(status["store"]).name
assert (store / "zarr.json").is_file(), f"{store} is not on the host"
print(f"   {expected}/{expected} experiments done in {store}", file=sys.stderr)
PY

# --- 5. the dashboard ----------------------------------------------------------------------
phase dashboard
python3 - "http://127.0.0.1:$FARM_DASHBOARD_PORT/status" <<'PY' || fail "dashboard"
import sys, urllib.request
with urllib.request.urlopen(sys.argv[1], timeout=30) as r:
    page = r.read().decode(errors="replace")
    assert r.status == 200, r.status
assert "needs bokeh" not in page, "the dashboard asks for bokeh: it is not in the image"
assert "bokeh" in page and "Dask" in page, page[:300]
print(f"   {sys.argv[1]}: 200, the Dask dashboard ({len(page)} bytes)", file=sys.stderr)
PY
# the farm's page (scheduler --preload jobs.dashboard): the finished sweep's solves
python3 - "http://127.0.0.1:$FARM_DASHBOARD_PORT/farm.json" <<'PY' || fail "farm page"
import json, sys, urllib.request
with urllib.request.urlopen(sys.argv[1], timeout=30) as r:
    state = json.loads(r.read())
done = [s for s in state["recent"] if s["status"] == "done"]
assert done and not state["failures"], state
print(f"   {sys.argv[1]}: the farm page, {len(done)} solves done", file=sys.stderr)
PY
