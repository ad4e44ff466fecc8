# Timed runs for the algebra benchmark scripts (bench/algebra-peers.sh,
# bench/algebra-implicit.sh). Source it after setting TIMEOUT (seconds) and
# TMP (a scratch folder). Defines
#   run NAME CMD...  runs CMD once with stdin closed, stdout in $TMP/NAME.out,
#                    stderr in $TMP/NAME.err; prints "seconds|MiB" (wall time
#                    to the millisecond from the shell's clock around the run,
#                    peak RSS from /usr/bin/time), "> T s|—" past TIMEOUT,
#                    "failed (RC)|—" on another nonzero exit;
#   num X            true when X is a plain number.
run() {
  local name="$1"; shift
  local rc=0 t0 t1
  t0=$(date +%s%N)
  timeout "$TIMEOUT" /usr/bin/time -f '%M' -o "$TMP/$name.time" "$@" </dev/null >"$TMP/$name.out" 2>"$TMP/$name.err" || rc=$?
  t1=$(date +%s%N)
  if [ "$rc" = 124 ]; then echo "> $TIMEOUT s|—"; return; fi
  if [ "$rc" != 0 ]; then echo "failed ($rc)|—"; return; fi
  awk -v ns=$((t1 - t0)) '{ printf "%.3f|%.0f", ns / 1e9, $1 / 1024 }' "$TMP/$name.time"
}
num() { [[ $1 =~ ^[0-9.]+$ ]]; }
