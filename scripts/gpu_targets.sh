#!/usr/bin/env bash
# The GPU-driven and scale targets' measurements on a GPU, in one call on a lent NVIDIA machine.
#
# Prepare .gpu/ as ../shared/gpu/run.sh's header says (data included, for castle-2114), then
# call the device tool's run with
#     command="bash scripts/gpu_targets.sh", carry=[".gpu"], timeout_s=570
# Each step runs under its own time limit (545 s in all, besides the runner's setup), so a slow
# step costs its limit and no more, and writes its log and BENCHMARKS sections to a folder of
# its own under $OUT (each section names the card's GL renderer).
#
# Dry run on this machine's llvmpipe, checking the script and not the GPU:
#     OUT=/tmp/gpu RUNNER= FRAMES=3 CITY_FRAMES=2 bash scripts/gpu_targets.sh
set -u
OUT=${OUT:?set OUT to the folder the results go to}
FRAMES=${FRAMES:-30}
CITY_FRAMES=${CITY_FRAMES:-20}
RUN=${RUNNER-bash .gpu/run.sh}  # RUNNER= (empty): this machine's python3
if [ -n "$RUN" ] && [ -z "${GPU_TARGETS_INSIDE:-}" ]; then
    # Once through the runner (it unpacks the GL loader and installs the wheels), not per step.
    export GPU_TARGETS_INSIDE=1 OUT FRAMES CITY_FRAMES
    exec $RUN bash "$0"
fi
# The GPU-driven rows: gpu-driven at both granularities, in both draw orders, its stages queued (the
# GPU default) and finished (sync=True); hiz-2phase likewise; the baselines.
METHODS="gpu-driven;gpu-driven(sync=True);gpu-driven(order='unsorted');"
METHODS+="gpu-driven(granularity='object');hiz-2phase;hiz-2phase(sync=True);"
METHODS+="hiz-2phase(granularity='cluster');hiz-gpu;frustum;queries"

step() {  # step NAME SECONDS COMMAND...: the command's output in $OUT/NAME/log.txt
    local name=$1 limit=$2
    shift 2
    mkdir -p "$OUT/$name"
    echo "== $(date +%T) $name (at most ${limit} s)"
    timeout "$limit" "$@" > "$OUT/$name/log.txt" 2>&1
    echo "   exit $?, ${SECONDS} s since the start"
    tail -n 3 "$OUT/$name/log.txt" | cut -c1-160
}

step gl 20 python3 -c "
import soc.gl.context as c
g = c.default_context()
print('renderer:', g.renderer, '| GL', g.ctx.version_code)
print('timer meaningful:', g.timer_meaningful, '| stages queued:', not g.stage_sync)"
step tests 100 python3 -m pytest -x -q -p no:cacheprovider \
    tests/soc/test_gpu_driven.py tests/soc/test_gpu_clock.py tests/soc/test_hiz_2phase.py
for scene_path in "castle-2114 flight" "castle-2114 walk" "market flight" "market walk"; do
    set -- $scene_path
    step "floor-$1-$2" 60 python3 -m benchmarks --only floor --scene "$1" --path "$2" \
        --frames "$FRAMES" --methods "$METHODS" --out "$OUT/floor-$1-$2"
done
# CPU microseconds per occlusion query from the compiled loops (target <= 1 us).
step queries 45 python3 -m benchmarks --only queries --out "$OUT/queries"
# The million-object city, both paths: cull <= 10 ms and cull + draw <= 1.2x the ideal
# at 1080p for hiz-2phase or gpu-driven, 0 false culls (on llvmpipe out of reach: see
# docs/findings.md, "Benchmarks"). Last: the step most likely
# to run out of time (the scene, its clusters and hierarchy take ~15 s to build).
CITY_METHODS="gpu-driven;gpu-driven(sync=True);hiz-2phase;hiz-2phase(occluders_first=True);frustum"
for path in flight walk; do
    step "floor-city-$path" 70 python3 -m benchmarks --only floor --scene city \
        --path "$path" --frames "$CITY_FRAMES" --methods "$CITY_METHODS" --out "$OUT/floor-city-$path"
done
echo "== done after ${SECONDS} s; results under $OUT"
