#!/usr/bin/env bash
# The whole shader benchmark in one go, for a GPU machine (or rehearsed on llvmpipe).
#
# On a bare NVIDIA machine: prepare the wheels and Mesa-free GL libraries (.whl/, .gl/) on a
# machine with the package registries, carry the checkout with them, then in its root
#     OUT=/some/dir bash tools/gpu_bench.sh
# Everywhere else it runs the checkout's package with the local GL (Mesa's llvmpipe here):
#     SMALL=1 bash tools/gpu_bench.sh        # the rehearsal: small sizes, a few minutes
# Writes to $OUT (default out/gpu_bench): device.txt (nvidia-smi, `blockhash info`),
# bench_A.txt/.json (every A: BH default, its merge selection, it without culling, the
# earlier default binary-branch-on-packed and paper, beside the fetch-only floor, the exact
# kd-tree shader and cKDTree, same run), bench_k.txt/.json (k at A = 8), bench_1m.txt/.json
# (1,048,576 queries; the walk beside hashing the same tables), caustic.txt/.json (the ring's
# caustic pass per stage at 10^6 photons, and with the k-nearest estimate beside the default),
# tests.txt (the GL lookup tests: every variant equals the CPU reference on this device),
# trace_speed.txt/.json and device_pass.txt/.json (the photons on DEVICE, default gpu there and
# cpu elsewhere: tracing alone beside Mitsuba's ptracer, and whole passes' photon stages in one
# process and on 1, 4 and 16 local workers; the wheels of Mitsuba and drjit must be in .whl/),
# frames_ring.txt/.json and frames_others.txt/.json (frames through the frame session: the
# ring's orbit and light circling at SIZE and FRAMES_BIG, FRAME_SPP (1 and 9) samples a pixel, venus and
# cbox at SIZE and 1, FRAME_PHOTONS a frame; tools/frames_bench.py's latency step).
# Figures: min and median of REPEAT back-to-back draws after WARMUP draws of the same program,
# GPU time (GL timer queries) beside wall time, with the renderer and driver in every row.
# STEPS (default device,A,k,1m,caustic,tests,photons,frames) names the steps to run; every step runs even
# when one before it failed, and the exit status is 1 when any failed.
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd); cd "$root"
OUT=$(mkdir -p "${OUT:-out/gpu_bench}" && cd "${OUT:-out/gpu_bench}" && pwd)
if [ "${SMALL:-0}" = 1 ]; then
  PHOTONS=${PHOTONS:-100000} QUERIES=${QUERIES:-16384} BIG=${BIG:-65536}
  CAUSTIC=${CAUSTIC:-100000} REPEAT=${REPEAT:-3} AS=${AS:-1,8} KS=${KS:-8,50}
  SIZE=${SIZE:-128} WORKERS=${WORKERS:-1,2} FRAMES_BIG=${FRAMES_BIG:-256}
  FRAME_PHOTONS=${FRAME_PHOTONS:-20000}
else
  PHOTONS=${PHOTONS:-1000000} QUERIES=${QUERIES:-262144} BIG=${BIG:-1048576}
  CAUSTIC=${CAUSTIC:-1000000} REPEAT=${REPEAT:-15} AS=${AS:-1,2,4,8,16} KS=${KS:-8,16,32,50}
  SIZE=${SIZE:-512} WORKERS=${WORKERS:-1,4,16} FRAMES_BIG=${FRAMES_BIG:-1024}
  FRAME_PHOTONS=${FRAME_PHOTONS:-100000}
fi
WARMUP=${WARMUP:-3}
FRAMES=${FRAMES:-6} FRAME_SPP=${FRAME_SPP:-1,9}
STEPS=",${STEPS:-device,A,k,1m,caustic,tests,photons,frames},"
failed=0
trap 'failed=1' ERR
if [ -f .whl/run.sh ] && command -v nvidia-smi >/dev/null; then
  bh() { bash .whl/run.sh "$@"; }                     # the installed wheel, NVIDIA's EGL
  py() { bash .whl/run.sh python3 "$@"; }
  DEVICE=${DEVICE:-gpu}
  tests() { bash .whl/run.sh pytest -q "$root/tests/gl/test_gl_lookup.py" "$root/tests/frame/test_caustic.py"; }
  nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv > "$OUT/device.txt"
else
  bh() { python -m blockhash "$@"; }                 # this checkout, the local GL
  py() { python "$@"; }
  DEVICE=${DEVICE:-cpu}
  tests() { python -m pytest -q -p no:cacheprovider tests/gl/test_gl_lookup.py -k "backends or register"; }
  : > "$OUT/device.txt"
fi
common=(--photons "$PHOTONS" --repeat "$REPEAT" --warmup "$WARMUP")
step() { echo "== $1 ($(date -u +%H:%M:%S))" >&2; }
wanted() { [[ $STEPS == *",$1,"* ]]; }
if wanted device; then
step "device"; bh info >> "$OUT/device.txt" 2>&1; cat "$OUT/device.txt"
fi
if wanted A; then
step "A sweep: $QUERIES queries, A=$AS"
bh bench "${common[@]}" --queries "$QUERIES" --A "$AS" --variants default,binary-set-on-merge-box,binary-set-on-packed,binary-branch-on-packed,paper \
   --json "$OUT/bench_A.json" | tee "$OUT/bench_A.txt"
fi
if wanted k; then
: > "$OUT/bench_k.txt"
step "k sweep at A=8: k=$KS"
for k in ${KS//,/ }; do
  bh bench "${common[@]}" --queries "$QUERIES" --A 8 --k "$k" --no-kdtree --variants default,binary-set-on-merge-box \
     --json "$OUT/bench_k$k.json" | tee -a "$OUT/bench_k.txt"
done
fi
if wanted 1m; then
step "$BIG queries at A=8"
bh bench "${common[@]}" --queries "$BIG" --A 8 --hashing --json "$OUT/bench_1m.json" | tee "$OUT/bench_1m.txt"
fi
if wanted caustic; then
step "caustic pass: scenes/ring.toml at $CAUSTIC photons"
bh bench --queries 0 --caustic "$root/scenes/ring.toml" --caustic-photons "$CAUSTIC" \
   --caustic-estimates unbiased --repeat "$REPEAT" --warmup "$WARMUP" --json "$OUT/caustic.json" | tee "$OUT/caustic.txt"
fi
if wanted tests; then
step "GL lookup tests"
tests > "$OUT/tests.txt" 2>&1; tail -n 3 "$OUT/tests.txt"
fi
if wanted photons; then
step "photons on $DEVICE: tracing alone, then whole passes at $SIZE x $SIZE, $CAUSTIC photons"
py "$root/tools/trace_speed.py" --scenes ring,sun,cbox --photons "$CAUSTIC" --size "$SIZE" \
   --repeat "$REPEAT" --device "$DEVICE" --json "$OUT/trace_speed.json" | tee "$OUT/trace_speed.txt"
py "$root/tools/device_pass.py" --scenes ring,venus,cbox --size "$SIZE" --photons "$CAUSTIC" \
   --workers "$WORKERS" --device "$DEVICE" --json "$OUT/device_pass.json" | tee "$OUT/device_pass.txt"
fi
if wanted frames; then
step "frames on $DEVICE: the ring at $SIZE and $FRAMES_BIG, venus and cbox at $SIZE"
BLOCKHASH_DEVICE="$DEVICE" py "$root/tools/frames_bench.py" --steps latency --scenes ring \
   --sizes "$SIZE,$FRAMES_BIG" --spp "$FRAME_SPP" --frames "$FRAMES" --photons "$FRAME_PHOTONS" \
   --json "$OUT/frames_ring.json" | tee "$OUT/frames_ring.txt"
BLOCKHASH_DEVICE="$DEVICE" py "$root/tools/frames_bench.py" --steps latency --scenes venus,cbox \
   --sizes "$SIZE" --spp 1 --frames "$FRAMES" --photons "$FRAME_PHOTONS" \
   --json "$OUT/frames_others.json" | tee "$OUT/frames_others.txt"
fi
if [ "$failed" = 0 ]; then step "done: $OUT"; else step "done, with failed steps: $OUT"; fi
exit "$failed"
