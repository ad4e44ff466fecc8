#!/usr/bin/env bash
# Times Singular on isoray-algebra's benchmark problems, over Q, degrevlex (dp):
#   std (options redSB, redTail: the reduced basis) of katsura-6, katsura-7,
#   cyclic-6, and eliminate(I, s*t*w) for each implicitization case of
#   systems.lib/implicitCases().
# Each case runs in its own Singular process under /usr/bin/time -v and a
# timeout (TIMEOUT seconds, default 600). Times are taken inside Singular
# (rtimer: wall, timer: CPU, 10 ms resolution; start-up and input construction
# excluded). A case faster than MIN_MS (default 1000) ms is repeated, the run
# count growing until one batch takes at least MIN_MS, and the mean per run of
# that batch is reported (so a run's result is reused by none: std/eliminate
# recompute from I each time).
# Prints a markdown table; "peak RSS" is the process's maximum resident set
# size (Singular start-up included; see the `(start-up...)` row), "memory(2)" is
# Singular's own count of the most memory it ever allocated.
# Usage: bench/singular/timing.sh [CASE...]   (default: all cases)
#   CASE: katsura-6 katsura-7 cyclic-6 implicit-1 .. implicit-9
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
TIMEOUT="${TIMEOUT:-600}"
MIN_MS="${MIN_MS:-1000}"

if ! command -v Singular >/dev/null; then
  echo "timing: Singular not found; run bench/install-peers.sh" >&2
  exit 1
fi
if [ ! -x /usr/bin/time ]; then
  echo "timing: /usr/bin/time not found (Debian package \`time\`)" >&2
  exit 1
fi

tmp="$(mktemp -d)"
child=""   # the running `timeout` (it signals its whole process group)
cleanup() {
  if [ -n "$child" ]; then kill "$child" 2>/dev/null || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

vars_range() { # vars_range FIRST LAST -> xFIRST,...,xLAST
  local s="" i
  for ((i = $1; i <= $2; i++)); do s+="${s:+,}x$i"; done
  echo "$s"
}

# case_setup CASE: Singular code that sets the ring and builds `ideal I`, then a
# line `//RUN <statement>`: the timed statement (sets `ideal R`).
case_setup() {
  local c="$1"
  case "$c" in
    katsura-*)
      local n="${c#katsura-}"
      echo "ring r = 0, ($(vars_range 0 "$n")), dp; option(redSB); option(redTail);"
      echo "ideal I = katsuraIdeal($n);"
      echo "//RUN R = std(I);" ;;
    cyclic-*)
      local n="${c#cyclic-}"
      echo "ring r = 0, ($(vars_range 1 "$n")), dp; option(redSB); option(redTail);"
      echo "ideal I = cyclicIdeal($n);"
      echo "//RUN R = std(I);" ;;
    implicit-*)
      local i="${c#implicit-}"
      echo "ring r = 0, (s,t,w,x,y,z), dp;"
      echo "ideal I = implicitIdeal(implicitCases()[$i]);"
      echo "//RUN R = eliminate(I, s*t*w);" ;;
    startup)
      echo "ring r = 0, (x), dp; ideal I = x;"
      echo "//RUN R = I;" ;;
    *) echo "timing: unknown case $c" >&2; return 1 ;;
  esac
}

label() {
  case "$1" in
    implicit-*)
      local i="${1#implicit-}"
      echo "implicit-$i: $(Singular -q -t --no-rc -c "LIB \"$here/systems.lib\"; print(implicitCases()[$i][7]); quit;" </dev/null)" ;;
    startup) echo "(start-up; timed: R = I)" ;;
    *) echo "$1" ;;
  esac
}

# run_case CASE: prints one markdown table row.
run_case() {
  local c="$1" sing="$tmp/$1.sing" log="$tmp/$1.log" tv="$tmp/$1.time" rc=0
  local setup; setup="$(case_setup "$c")"
  local stmt; stmt="$(sed -n 's|^//RUN ||p' <<<"$setup")"
  {
    echo "LIB \"$here/systems.lib\";"
    echo 'system("--ticks-per-sec", 1000000);'
    grep -v '^//RUN ' <<<"$setup"
    cat <<'SING'
ideal R;
int reps = 1;
int k, w0, c0, wall, cpu;
while (1)
{
  w0 = rtimer; c0 = timer;
  for (k = 1; k <= reps; k++) { RUN_STMT }
  wall = rtimer - w0; cpu = timer - c0;
  if (wall >= MIN_US || reps >= 1000000) { break; }
  // next batch: aim at 1.2 * MIN_US, at most 10x the runs (bigint: no overflow)
  bigint b = reps;
  b = b * (MIN_US div 5 * 6) div (wall + 1) + 1;
  if (b > 10 * reps) { b = 10 * reps; }
  if (b > 1000000) { b = 1000000; }
  reps = int(b);
  kill b;
}
"RESULT " + string(wall) + " " + string(cpu) + " " + string(reps) + " " + string(memory(2)) + " " + string(size(R));
quit;
SING
  } | sed -e "s/MIN_US/$((MIN_MS * 1000))/g" -e "s|RUN_STMT|$stmt|" >"$sing"

  timeout "$TIMEOUT" /usr/bin/time -v -o "$tv" \
    Singular -q -t --no-rc "$sing" </dev/null >"$log" 2>&1 &
  child=$!
  wait "$child" || rc=$?
  child=""
  local name; name="$(label "$c")"
  if [ "$rc" -eq 124 ]; then
    echo "| $name | timeout (>${TIMEOUT} s) | | | | |"
    return
  fi
  local res; res="$(grep '^RESULT ' "$log" || true)"
  if [ "$rc" -ne 0 ] || [ -z "$res" ] || grep -q '^ *?' "$log"; then
    echo "timing: $c failed (rc $rc):" >&2; cat "$log" >&2
    echo "| $name | error | | | | |"
    return
  fi
  local rss_kb; rss_kb="$(awk -F': ' '/Maximum resident set size/ {print $2}' "$tv")"
  # shellcheck disable=SC2086
  set -- $res
  awk -v name="$name" -v wall="$2" -v cpu="$3" -v reps="$4" -v mem="$5" -v rss="$rss_kb" 'BEGIN {
    printf "| %s | %.3f | %.3f | %d | %.1f | %.1f |\n", name,
      wall / reps / 1000, cpu / reps / 1000, reps, rss / 1024, mem / 1048576 }'
}

cases=("$@")
if [ ${#cases[@]} -eq 0 ]; then
  cases=(startup katsura-6 katsura-7 cyclic-6)
  for i in 1 2 3 4 5 6 7 8 9; do cases+=("implicit-$i"); done
fi

echo "Singular: $(Singular --version 2>&1 | head -n1)"
echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')"
echo
echo "| case | Singular ms (wall) | CPU ms | runs | peak RSS MiB | memory(2) MiB |"
echo "|---|---:|---:|---:|---:|---:|"
for c in "${cases[@]}"; do
  run_case "$c"
done
