#!/usr/bin/env bash
# The main job (README): set up, then run the thesis' chapter-5 dataset on the embedded
# Dask cluster (LocalCluster, one worker per core) into results/thesis.zarr.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
exec farm sweep submit examples/thesis_ch5_dataset.toml "$@"
