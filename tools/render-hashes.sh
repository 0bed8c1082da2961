#!/bin/bash
# Renders a fixed set of shots of the samples and prints one hash per output (the framemd5 of
# each video, the md5 of each preview PNG). Run it before and after a change that should not
# change any picture, and compare: `tools/render-hashes.sh OUT_DIR > before.txt`.
# BIN picks the binary (default: the release build).
set -u
BIN=${BIN:-./target/release/rain-composite}
OUT=${1:?usage: tools/render-hashes.sh OUT_DIR}
S=samples
mkdir -p "$OUT"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
cat > "$OUT/keyed.json" <<'J'
{"camera": {"pan_deg": [[0, 0], [1, 20]]}, "rain": {"rate_mm_per_h": [[0, 5], [1, 40]]}}
J
render() { "$BIN" "$@" -y 2>&1 | grep -i error; }
render $S/city.mp4 -o "$OUT/city.mkv"
render $S/city.mp4 -o "$OUT/city_preset.mkv" --config samples/presets/city.json
render $S/daylight.mp4 -o "$OUT/daylight_mattes.mkv" --streaks mattes --frames 0..12
render $S/street.mp4 -o "$OUT/street_puddles.mkv" --rain 20 --pre-rain 20 \
    --ground horizon=0.48 --scene-depth 30 --puddles --frames 0..10
render $S/street.mp4 -o "$OUT/street_keyed.mkv" --config "$OUT/keyed.json" --frames 0..15
render $S/sunset.mp4 -o "$OUT/sunset_layer.mov" --layer-only --frames 0..8
render $S/street.mp4 -o "$OUT/street_auto.mkv" --ground auto --frames 0..8
render preview $S/city.mp4 --at 1 -o "$OUT/city_1.png"
render preview $S/street.mp4 --at 0.5 -o "$OUT/street_puddles.png" --rain 20 --pre-rain 20 \
    --ground horizon=0.48 --scene-depth 30 --puddles
render preview $S/street.mp4 --at 0.5 -o "$OUT/street_keyed.png" --config "$OUT/keyed.json"
for f in "$OUT"/*.mkv "$OUT"/*.mov; do
    [ -f "$f" ] || continue
    md5=$(ffmpeg -v error -i "$f" -map 0:v -f framemd5 - | grep -v '^#')
    echo "$(basename "$f") $(echo "$md5" | md5sum | cut -c1-16) frames=$(echo "$md5" | grep -c .)"
done
for f in "$OUT"/*.png; do echo "$(basename "$f") $(md5sum < "$f" | cut -c1-16)"; done
