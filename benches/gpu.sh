#!/bin/bash
# GPU figures: renders of one clip at several rain rates and drop budgets, each with its wall
# time and the GPU time of every stage (timestamp queries), as a Markdown table. Render-only fps
# is 1 / (the stages' GPU time per frame): decode and encode left out.
#
#   BIN=target/release/rain-composite benches/gpu.sh IN.mp4 OUT_DIR [RENDER FLAGS…]
#
# Flags after OUT_DIR go to every render (`--streaks mattes` gives the table for the mattes).
# The lossless FFV1 output keeps the encoder's cost small and the same for every row.
# A render paced by its encoder leaves the GPU idle most of each frame, so its clock may not settle:
# compare days with `cargo bench --bench gpu_frame` (the GPU stages in a loop), not with these rows.
set -u
BIN=${BIN:-./target/release/rain-composite}
IN=${1:?usage: benches/gpu.sh IN.mp4 OUT_DIR}
OUT=${2:?usage: benches/gpu.sh IN.mp4 OUT_DIR}
shift 2
EXTRA=("$@")
mkdir -p "$OUT"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
"$BIN" adapters
echo "| rain mm/h | drop budget | drops drawn a frame | frames | wall fps | GPU yuv→rgb ms | GPU rain ms | GPU rgb→yuv ms | render-only fps |"
echo "|---|---|---|---|---|---|---|---|---|"
for spec in "10 300000" "75 128960" "75 300000" "150 1000000"; do
    set -- $spec
    "$BIN" "$IN" -o "$OUT/rain.mkv" -y --codec ffv1 --rain "$1" --max-drops "$2" \
        "${EXTRA[@]}" --progress json 2> "$OUT/log-$1-$2.txt" >/dev/null
    tail -n 1 "$OUT/log-$1-$2.txt" | python3 -c '
import json, sys
s = json.load(sys.stdin); g = s["stages"]["gpu"]; n = max(s["frames"], 1)
ms = lambda v: 1000.0 * v / n
rain = g["rain_simulate_s"] + g["rain_splashes_s"] + g["rain_streaks_s"]
gpu = g["yuv_to_rgb_s"] + rain + g["rgb_to_yuv_s"]
print("| %s | %s | %d | %d | %.1f | %.3f | %.3f | %.3f | %.0f |" % (sys.argv[1], sys.argv[2],
      s["drops"], s["frames"], s["frames"] / s["elapsed_s"], ms(g["yuv_to_rgb_s"]), ms(rain),
      ms(g["rgb_to_yuv_s"]), n / gpu if gpu > 0 else float("nan")))
print(s["adapter"], file=sys.stderr)' "$1" "$2"
done
