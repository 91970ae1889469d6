#!/usr/bin/env bash
# The test command (README, .ci/run): set up, lint, then run the default test suite.
#   bash scripts/test.sh            default suite (what CI runs)
#   bash scripts/test.sh --slow     only the slow tests (default-size meshes, long sweeps)
#   bash scripts/test.sh --e2e      only the end-to-end runs (CI runs them after the default suite)
#   bash scripts/test.sh -k frd     any other arguments go to pytest
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
# This command installs ccx itself, so a test that needs ccx must never skip here.
export FARM_REQUIRE_CCX=1
ruff check .
mypy  # [tool.mypy] in pyproject.toml names what it checks
# the documentation site, warnings as errors (mkdocs.yml: strict); built to a scratch folder
docs_site="$(mktemp -d)"
mkdocs build --strict --quiet --site-dir "$docs_site"
rm -rf "$docs_site"
if [ "${1:-}" = "--slow" ]; then
    shift
    exec python -m pytest -m slow "$@"
fi
if [ "${1:-}" = "--e2e" ]; then
    shift
    # the farm's dashboard page is tested in a real browser: Debian's chromium
    command -v chromium >/dev/null || apt_install chromium
    export FARM_REQUIRE_CHROMIUM=1
    exec python -m pytest -m e2e "$@"
fi
# the 25 slowest tests are listed at the end: the default run aims at about 15 min
exec python -m pytest --durations=25 "$@"
