#!/usr/bin/env bash
# The main job (README): set up, then reproduce the thesis study (chapters 3-5) on the
# embedded Dask cluster (LocalCluster, one worker per core): validation curves, the
# chapter-5 dataset and analyses, the chapter-4 inverse problems, and a report beside
# the thesis' values in reproduction/report.md. A second run reuses the store.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
exec farm reproduce --quick "$@"
