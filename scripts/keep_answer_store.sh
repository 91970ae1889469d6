#!/usr/bin/env bash
# Bring the answer's store (issue 46) from the clone its sweep runs in into this
# checkout, checked, ready to commit (docs/answer.md, "Where the store is kept").
#
#   bash scripts/keep_answer_store.sh /work/studies/t2cam    # then git add results/...
#   bash scripts/keep_answer_store.sh CLONE DEST              # into DEST, not this checkout
#
# Why: the study takes some 15 h of two cores and a session some 3 h; a new machine
# starts from the repository alone, so a store kept anywhere else is lost with it. The
# sweep runs in a clone (its workers import that clone's code; this checkout changes
# under them otherwise). Stop the sweep first: a store copied while a worker writes may
# hold a torn chunk, which `farm sweep verify` below reports (exit 1, nothing replaced).
# The workers' claims and the client lock stay behind. The saved trunks (about 5 MB
# each on `lean`) come along: a tree cut by the stop rolls its remaining branches from
# its saved trunk, not from rest; a damaged one reads as absent (the trunk is rolled again).
set -euo pipefail

STORE=results/t2cam_rolling.zarr
clone=${1:?usage: bash scripts/keep_answer_store.sh CLONE [DEST] (CLONE: the checkout the sweep ran in)}
repo=$(cd "$(dirname "$0")/.." && pwd)
here=$(cd "${2:-$repo}" && pwd)
src="$clone/$STORE"
farm="$repo/.venv/bin/farm"
[[ -x "$farm" ]] || farm=farm

[[ -d "$src" ]] || { echo "keep_answer_store: no store at $src: give the clone its sweep ran in" >&2; exit 1; }
[[ "$(cd "$clone" && pwd)" != "$here" ]] || { echo "keep_answer_store: $clone is this checkout: give the sweep's clone" >&2; exit 1; }

new="$here/$STORE.incoming"
rm -rf "$new"
mkdir -p "$new"
trap 'rm -rf "$new"' EXIT
(cd "$src" && tar --exclude=./.claims --exclude=./.farm.lock -cf - .) \
    | (cd "$new" && tar -xf -)
if ! "$farm" sweep verify "$new"; then
    echo "keep_answer_store: the copy of $src is damaged (above); was the sweep stopped? $here/$STORE is unchanged" >&2
    exit 1
fi
rm -rf "$here/$STORE"
mv "$new" "$here/$STORE"
du -sh "$here/$STORE"
[[ ! -f "$here/examples/t2cam_rolling.toml" ]] \
    || (cd "$here" && "$farm" sweep status examples/t2cam_rolling.toml) | tail -n 3 || true
