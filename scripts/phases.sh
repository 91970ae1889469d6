# Sourced by the end-to-end test scripts: named phases with their times.
#   phase build        # ends the previous phase (if any), starts "build"
#   print_timings      # ends the last phase, prints every phase's seconds on stderr
phase_name="" phase_start=$SECONDS timings=()
phase() {
    [ -z "$phase_name" ] || timings+=("$(printf '%-10s %4d s' "$phase_name" $((SECONDS - phase_start)))")
    phase_name="$1" phase_start=$SECONDS
    [ -z "$1" ] || echo "== $1" >&2
}
print_timings() {
    phase ""
    echo "== timings" >&2
    printf '   %s\n' "${timings[@]}" >&2
}
