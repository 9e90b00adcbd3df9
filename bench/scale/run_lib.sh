# Shared by the scale benchmarks: run NAME N CMD... prints one JSON record (wall, user,
# system CPU, peak RSS, exit status, load before) of CMD under ulimit -v (vlimit_kb).
# Needs $work set by the caller.
vlimit_kb=${vlimit_kb:-$((6 * 1024 * 1024))}  # never more than 6 GiB of address space
run() {  # run NAME N CMD...: one JSON record on stdout
  local name="$1" n="$2"; shift 2
  local t="$work/time.txt" load; load="$(cut -d' ' -f1-3 /proc/loadavg)"
  ( ulimit -v "$vlimit_kb"; /usr/bin/time -v "$@" ) 2>"$t" >/dev/null || true
  local wall user sys rss rc
  wall="$(awk -F': ' '/Elapsed \(wall/ {print $2}' "$t")"
  user="$(awk -F': ' '/User time/ {print $2}' "$t")"; sys="$(awk -F': ' '/System time/ {print $2}' "$t")"
  rss="$(awk -F': ' '/Maximum resident/ {print $2}' "$t")"; rc="$(awk -F': ' '/Exit status/ {print $2}' "$t")"
  printf '{"run":"%s","n":%s,"voxels":%s,"wall":"%s","user_s":%s,"sys_s":%s,"peak_rss_kb":%s,"exit":%s,"load_before":"%s"}\n' \
    "$name" "$n" "$((n * n * n))" "$wall" "$user" "$sys" "$rss" "$rc" "$load"
}
