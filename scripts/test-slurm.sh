#!/usr/bin/env bash
# End-to-end test of the farm on a real SLURM (docs/scale-out.md, "SLURM"): start a
# single-node SLURM with scripts/slurm-local.sh unless one answers already, make sure the
# venv has dask-jobqueue, run the tests marked `slurm` (the quick sweep as SLURM jobs, the
# store and `squeue` checked), fail if they were skipped, and stop SLURM again if this
# script started it (also on failure). Prints the time each phase took. Run as root.
#
#   bash scripts/test-slurm.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

source "$root/scripts/phases.sh"
fail() { echo "test-slurm: FAILED: $*" >&2; exit 1; }

started_slurm=0
log="$(mktemp "${TMPDIR:-/tmp}/tyre-farm-slurm.XXXXXX.log")"
finish() {
    local rc=$?
    trap - EXIT
    set +e
    if [ "$started_slurm" = 1 ]; then
        phase stop
        bash scripts/slurm-local.sh --stop >&2
    fi
    print_timings
    echo "test-slurm: $([ "$rc" = 0 ] && echo passed || echo "FAILED (rc $rc)") in $SECONDS s" >&2
    rm -f "$log"
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
