#!/usr/bin/env bash
# End-to-end test of the farm on a real SLURM (docs/scale-out.md, "SLURM"): start a
# single-node SLURM with scripts/slurm-local.sh unless one answers already, make sure the
# venv has dask-jobqueue, run the tests marked `slurm` (the quick sweep as SLURM jobs, the
# store and `squeue` checked), fail if they were skipped, then run the quick sweep the way
# users do - `farm sweep submit STUDY --cluster slurm ...` - and, while it runs, fetch its
# dashboard's /status page (the real bokeh page, not "needs bokeh"); check the summary,
# the store and that no job outlived the run. Stops SLURM again if this script started
# it (also on failure). Prints the time each phase took. Run as root.
#
#   bash scripts/test-slurm.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

source "$root/scripts/phases.sh"
fail() { echo "test-slurm: FAILED: $*" >&2; exit 1; }

started_slurm=0 farm_pid=""
log="$(mktemp "${TMPDIR:-/tmp}/tyre-farm-slurm.XXXXXX.log")"
work="$(mktemp -d "${TMPDIR:-/tmp}/tyre-farm-slurm-cli.XXXXXX")"
finish() {
    local rc=$?
    trap - EXIT
    set +e
    if [ -n "$farm_pid" ] && kill -0 "$farm_pid" 2>/dev/null; then
        kill -INT "$farm_pid"; wait "$farm_pid"  # its client cancels its SLURM jobs
    fi
    if [ "$started_slurm" = 1 ]; then
        phase stop
        bash scripts/slurm-local.sh --stop >&2
    fi
    print_timings
    echo "test-slurm: $([ "$rc" = 0 ] && echo passed || echo "FAILED (rc $rc)") in $SECONDS s" >&2
    rm -rf "$log" "$work"
    exit "$rc"
}
trap finish EXIT

phase setup
[ -x .venv/bin/python ] || bash scripts/setup.sh
# the `slurm` extra of pyproject.toml (scripts/setup.sh installs it; a venv made before may lack it)
.venv/bin/python -c 'import dask_jobqueue' 2>/dev/null \
    || .venv/bin/python -m pip install -q -e ".[slurm]" --config-settings editable_mode=compat

phase slurm
if ! scontrol ping 2>/dev/null | grep -q 'is UP'; then
    bash scripts/slurm-local.sh
    started_slurm=1
fi
sinfo >&2

phase tests
# -rs lists skip reasons; a skip here means SLURM was not usable: that is a failure
FARM_REQUIRE_CCX=1 .venv/bin/python -m pytest tests/jobs/test_jobs_slurm.py -m slurm -rs \
    -p no:cacheprovider 2>&1 | tee "$log" || fail "pytest failed"
grep -q -E "^SKIPPED|[0-9]+ skipped" "$log" && fail "the SLURM tests were skipped"
grep -q -E "[0-9]+ passed" "$log" || fail "no SLURM test ran"

phase cli
# The quick study of tests/jobs/conftest.py; the SLURM job's own output goes to $work.
.venv/bin/python -c "
import sys
from tests.jobs.conftest import study_text
print(study_text(sys.argv[1] + '/store.zarr', deflections='[10, 20, 30]'))
" "$work" > "$work/study.toml"
port="$(.venv/bin/python -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
job="tyre-farm-cli-$$"
(cd "$work" && exec "$root/.venv/bin/farm" sweep submit study.toml --cluster slurm \
    --slurm-partition debug --slurm-jobs 1 --slurm-cores 1 --slurm-memory 1GiB \
    --slurm-walltime 00:15:00 --slurm-interface lo --slurm-dashboard "127.0.0.1:$port" \
    --slurm-job-name "$job" --json >summary.json 2>sweep.log) &
farm_pid=$!
# The dashboard is up as soon as the scheduler is, before the first SLURM job starts:
# read it while the sweep runs.
url="http://127.0.0.1:$port/status"
until curl -sf --max-time 10 "$url" -o "$work/status.html"; do
    kill -0 "$farm_pid" 2>/dev/null || { cat "$work/sweep.log" >&2; fail "the sweep ended before $url answered"; }
    sleep 0.5
done
wait "$farm_pid" || { rc=$?; cat "$work/sweep.log" >&2; fail "farm sweep submit --cluster slurm exited $rc"; }
farm_pid=""
cat "$work/sweep.log" >&2
grep -q "dashboard" "$work/sweep.log" || fail "the sweep did not say where its dashboard is"
.venv/bin/python - "$work" "$url" <<'PY' || fail "the CLI sweep on SLURM"
import json, pathlib, sys
import storage
work, url = pathlib.Path(sys.argv[1]), sys.argv[2]
page = (work / "status.html").read_text()
assert "needs bokeh" not in page, "the dashboard asks for bokeh"
assert "bokeh" in page and "Dask" in page, page[:300]
print(f"   {url}: the Dask dashboard ({len(page)} bytes)", file=sys.stderr)
summary = json.loads((work / "summary.json").read_text())
assert summary["ok"] and summary["done_now"] == 3 and not summary["failed"], summary
counts = storage.status_counts(str(work / "store.zarr"), summary["group"])
assert counts == {"pending": 0, "done": 3, "failed": 0}, counts
print(f"   farm sweep submit --cluster slurm: {counts}, {summary['wall_seconds']} s", file=sys.stderr)
PY
for _ in $(seq 60); do [ -z "$(squeue -h -n "$job")" ] && break; sleep 1; done
[ -z "$(squeue -h -n "$job")" ] || fail "SLURM jobs $job outlived the sweep"
