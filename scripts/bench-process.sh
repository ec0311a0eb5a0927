#!/usr/bin/env bash
# Benchmark of `bendscope process` (issue: the main job), all figures measured in the
# same run on this machine:
# - a 10 s 1080p30 H.264 video at ~40 Mb/s with sensor noise: frames/s of
#   `ffmpeg -threads 0 -i VIDEO -f null -` (decode only, the baseline), of bendscope
#   (detect in the raw frame, undistort the centroids) and of the seed method (undistort
#   every whole frame, then HSV), and the ratios;
# - a 4K 60 fps 10-bit HEVC video with an audio and a timecode track (as a GoPro
#   records): frames/s of ffmpeg decode-only and of bendscope, the ratio, and bendscope's
#   peak memory (max RSS);
# - the 1080p video again with green markers: its ratio beside red's;
# - peak memory of bendscope on a 4K H.264 video.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin bendscope --example bench_video
dir=target/bench/proc1080
[ -f "$dir/GX010001.MP4" ] || target/release/examples/bench_video "$dir" 1920 1080 300 40
dir4k=target/bench/proc4k
# 4 s of 4K at 60 fps, every frame distinct (as a GoPro records): a duplicated frame
# decodes almost for free and would flatter the decoder-only baseline.
[ -f "$dir4k/GX010001.MP4" ] || target/release/examples/bench_video "$dir4k" 3840 2160 240 120 60
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
# The same video with green markers (`[detect] colour = "green"`: the pre-test scans both
# chroma planes instead of Cr alone): its ratio to decode-only beside red's.
dirg=target/bench/proc1080green
[ -f "$dirg/GX010001.MP4" ] || target/release/examples/bench_video "$dirg" 1920 1080 300 40 30 green
t_ffg=$(best ffmpeg -hide_banner -loglevel error -threads 0 -i "$dirg/GX010001.MP4" -f null -)
t_bsg=$(best target/release/bendscope process "$dirg" --force -o target/bench/out1080green)
awk -v n="$frames" -v f="$t_ffg" -v b="$t_bsg" -v rf="$t_ff" -v rb="$t_bs" 'BEGIN {
  printf "1080p30 green markers, %d frames\n", n
  printf "  ffmpeg decode only : %6.1f fps (%.2f s)\n", n / f, f
  printf "  bendscope process  : %6.1f fps (%.2f s)  = %.2f x decode-only (red: %.2f x; green/red %.3f)\n", n / b, b, f / b, rf / rb, (f / b) / (rf / rb)
}'
grep -E "^GX" target/bench/out1080green/per_video.csv | cut -d, -f1-3 | sed 's/^/  result (true radius 90 mm): /'
/usr/bin/time -v target/release/bendscope process "$dir4k" --force -o target/bench/out4k 2> target/bench/time4k.txt > /dev/null
echo "4K (3840x2160): peak memory $(awk '/Maximum resident/ { printf "%.0f MB", $6 / 1024 }' target/bench/time4k.txt)"
dir10=target/bench/proc4k10
if [ ! -f "$dir10/GX010001.MP4" ]; then
  mkdir -p "$dir10"
  cp "$dir4k"/pressures.csv "$dir4k"/scale.* "$dir10"/ 2>/dev/null || true
  cp -r "$dir4k"/*.toml "$dir4k"/*.yaml "$dir10"/ 2>/dev/null || true
  [ -d "$dir4k/calib" ] && cp -r "$dir4k/calib" "$dir10"/
  ffmpeg -v error -y -i "$dir4k/GX010001.MP4" -f lavfi -i sine=d=4 -map 0:v -map 1:a \
    -c:v libx265 -preset ultrafast -pix_fmt yuv420p10le -x265-params log-level=error:bitrate=100000 \
    -c:a aac -timecode 01:00:00:00 -shortest "$dir10/GX010001.MP4"
fi
v10="$dir10/GX010001.MP4"
n10=$(ffprobe -v error -select_streams v:0 -count_packets -show_entries stream=nb_read_packets -of csv=p=0 "$v10")
t_ff10=$(best ffmpeg -hide_banner -loglevel error -threads 0 -i "$v10" -f null -)
t_bs10=$(best target/release/bendscope process "$dir10" --force -o target/bench/out4k10)
/usr/bin/time -v target/release/bendscope process "$dir10" --force -o target/bench/out4k10 2> target/bench/time4k10.txt > /dev/null
awk -v n="$n10" -v f="$t_ff10" -v b="$t_bs10" 'BEGIN {
  printf "4K 10-bit HEVC + audio + timecode, %d frames\n", n
  printf "  ffmpeg decode only : %6.1f fps (%.2f s)\n", n / f, f
  printf "  bendscope process  : %6.1f fps (%.2f s)  = %.2f x decode-only\n", n / b, b, f / b
}'
echo "  peak memory $(awk '/Maximum resident/ { printf "%.0f MB", $6 / 1024 }' target/bench/time4k10.txt)"
grep -E "^GX" target/bench/out4k10/per_video.csv | cut -d, -f1-3 | sed 's/^/  result: /'
