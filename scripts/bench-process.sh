#!/usr/bin/env bash
# Benchmark of `bendscope process` (issue: the main job), all figures measured in the
# same run on this machine:
# - a 10 s 1080p30 H.264 video at ~40 Mb/s with sensor noise: frames/s of
#   `ffmpeg -threads 0 -i VIDEO -f null -` (decode only, the baseline), of bendscope
#   (detect in the raw frame, undistort the centroids) and of the seed method (undistort
#   every whole frame, then HSV), and the ratios;
# - peak memory (max RSS) of bendscope on a 4K video.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin bendscope --example bench_video
dir=target/bench/proc1080
[ -f "$dir/GX010001.MP4" ] || target/release/examples/bench_video "$dir" 1920 1080 300 40
dir4k=target/bench/proc4k
[ -f "$dir4k/GX010001.MP4" ] || target/release/examples/bench_video "$dir4k" 3840 2160 60 80
video="$dir/GX010001.MP4"
frames=$(ffprobe -v error -select_streams v:0 -count_packets -show_entries stream=nb_read_packets -of csv=p=0 "$video")
best() { # best of 3 wall-clock seconds of a command
  local b=999999 s e t
  for _ in 1 2 3; do
    s=$(date +%s.%N); "$@" > /dev/null 2>&1; e=$(date +%s.%N)
    t=$(awk -v a="$s" -v b="$e" 'BEGIN { print b - a }')
    b=$(awk -v a="$b" -v c="$t" 'BEGIN { print (c < a) ? c : a }')
  done
  echo "$b"
}
t_ff=$(best ffmpeg -hide_banner -loglevel error -threads 0 -i "$video" -f null -)
t_bs=$(best target/release/bendscope process "$dir" --force -o target/bench/out1080)
t_seed=$(best target/release/bendscope process "$dir" --force --config "$dir/seed.toml" -o target/bench/out1080seed)
awk -v n="$frames" -v f="$t_ff" -v b="$t_bs" -v s="$t_seed" 'BEGIN {
  printf "1080p30, %d frames, ~40 Mb/s H.264\n", n
  printf "  ffmpeg decode only : %6.1f fps (%.2f s)\n", n / f, f
  printf "  bendscope process  : %6.1f fps (%.2f s)  = %.2f x decode-only\n", n / b, b, f / b
  printf "  seed (full-frame)  : %6.1f fps (%.2f s)  = %.2f x decode-only; bendscope is %.2f x faster\n", n / s, s, f / s, s / b
}'
grep -E "^GX" target/bench/out1080/per_video.csv | cut -d, -f1-3 | sed 's/^/  result (true radius 90 mm): /'
/usr/bin/time -v target/release/bendscope process "$dir4k" --force -o target/bench/out4k 2> target/bench/time4k.txt > /dev/null
echo "4K (3840x2160): peak memory $(awk '/Maximum resident/ { printf "%.0f MB", $6 / 1024 }' target/bench/time4k.txt)"
