#!/usr/bin/env bash
# Side-by-side benchmark: isoray's Groebner engine vs Singular, on one machine,
# in one run.
#
#   bench/algebra.sh                 # all cases; REPS=5 bench/algebra.sh for more runs
#   bench/algebra.sh katsura-6 implicit-4   # a subset
#
# 1. installs the peers (bench/install-peers.sh), builds isoray
#    (cargo build --release -p isoray) and copies the binary to a temp dir, so
#    that a rebuild during the run does not change what is measured;
# 2. for each case, REPS times (default 3): one isoray run, then one Singular
#    run (alternating), each in its own process under /usr/bin/time -v (peak
#    RSS) and a timeout (TIMEOUT seconds, default 600);
# 3. prints a markdown table of medians (also written to bench/out/algebra.md).
#
# Cases: reduced Groebner basis over Q, grevlex (Singular `dp`, options redSB,
# redTail) of katsura-6, katsura-7, cyclic-6; implicit-1..9 (Singular:
# eliminate(I, s*t*w), I = systems.lib/implicitIdeal; isoray: `isoray
# implicitize`).
#
# Times are taken inside each program, start-up and input parsing excluded:
#   isoray:   the `time: X s` line of --stats (printed with 1 µs resolution);
#   Singular: bench/singular/timing.sh (rtimer around std/eliminate). timing.sh
#             repeats a case until a batch lasts MIN_MS; here MIN_MS defaults to
#             0 (one computation per process, like isoray). MIN_MS=1000 gives
#             timing.sh's own default: a warm mean over many runs.
# Peak RSS is the whole process's maximum resident set size (start-up included;
# see the `(start-up)` row).
# isoray's result is checked against the reference data in
# crates/isoray-algebra/tests/data/ (computed with Singular by
# bench/singular/reference.sh). A case without a data file there (katsura-7)
# gets its input and reference basis from Singular, computed in this run
# (untimed) into the temp dir.
set -euo pipefail

REPS=${REPS:-3}
TIMEOUT=${TIMEOUT:-600}
MIN_MS=${MIN_MS:-0}
CMDLINE="REPS=$REPS TIMEOUT=$TIMEOUT MIN_MS=$MIN_MS bench/algebra.sh${*:+ $*}"

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
DATA=crates/isoray-algebra/tests/data
SING_DIR=bench/singular

case "$REPS" in '' | *[!0-9]* | 0) echo "algebra: REPS must be a positive integer" >&2; exit 2 ;; esac

cases=("$@")
if [ ${#cases[@]} -eq 0 ]; then
  cases=(startup katsura-6 katsura-7 cyclic-6)
  for i in 1 2 3 4 5 6 7 8 9; do cases+=("implicit-$i"); done
fi
for c in "${cases[@]}"; do
  case "$c" in
    startup | katsura-[0-9]* | cyclic-[0-9]* | implicit-[1-9]) ;;
    *) echo "algebra: unknown case $c (katsura-N, cyclic-N, implicit-1..9, startup)" >&2; exit 2 ;;
  esac
done

bench/install-peers.sh >&2
cargo build --release -p isoray >&2
[ -x /usr/bin/time ] || { echo "algebra: /usr/bin/time not found (Debian package \`time\`)" >&2; exit 1; }

TMP=$(mktemp -d "${TMPDIR:-/tmp}/isoray-algebra.XXXXXX")
child=""   # the running `timeout`
cleanup() {
  if [ -n "$child" ]; then kill "$child" 2>/dev/null || true; fi
  rm -rf "$TMP"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
mkdir -p bench/out

ISORAY="$TMP/isoray"
cp target/release/isoray "$ISORAY"

# --- helpers -----------------------------------------------------------------

# median of the arguments (numbers), printed with format $1
median() {
  local fmt="$1"; shift
  printf '%s\n' "$@" | sort -g | awk -v fmt="$fmt" '{ v[NR] = $1 }
    END { if (NR % 2) m = v[(NR + 1) / 2]; else m = (v[NR / 2] + v[NR / 2 + 1]) / 2;
          printf fmt, m }'
}

# normalize a polynomial per line: no spaces (isoray prints ` + `, Singular `+`)
nospace() { tr -d ' \t\r'; }

# terms of one polynomial (on stdin), one per line, sorted
terms() { nospace | sed -e 's/-/+-/g' -e 's/^+//' | tr '+' '\n' | sort; }

vars_range() { # vars_range FIRST LAST -> xFIRST,...,xLAST
  local s="" i
  for ((i = $1; i <= $2; i++)); do s+="${s:+,}x$i"; done
  echo "$s"
}

# reference_file CASE: path of the data file of a Groebner case; generated with
# Singular into $TMP (the format of bench/singular/reference.sh) when the crate
# has none.
reference_file() {
  local c="$1"
  if [ -f "$DATA/$c.txt" ]; then echo "$DATA/$c.txt"; return; fi
  local f="$TMP/ref-$c.txt" n kind vars
  if [ ! -f "$f" ]; then
    n="${c#*-}"
    case "$c" in
      katsura-*) kind=katsuraIdeal; vars="$(vars_range 0 "$n")" ;;
      cyclic-*) kind=cyclicIdeal; vars="$(vars_range 1 "$n")" ;;
    esac
    echo "algebra: $c: no $DATA/$c.txt; computing input and reference with Singular (untimed)" >&2
    cat >"$TMP/ref-$c.sing" <<SING
LIB "$ROOT/$SING_DIR/systems.lib";
ring r = 0, ($vars), dp;
ideal I = $kind($n);
ideal G = writeReference("$f", "$vars", I);
quit;
SING
    if ! timeout "$TIMEOUT" Singular -q -t --no-rc "$TMP/ref-$c.sing" </dev/null >"$TMP/ref-$c.log" 2>&1 \
      || grep -q '^ *?' "$TMP/ref-$c.log" || [ ! -s "$f" ]; then
      echo "algebra: Singular failed to compute the reference for $c:" >&2
      cat "$TMP/ref-$c.log" >&2
      rm -f "$f"
      return 1
    fi
  fi
  echo "$f"
}

# run_timed OUT ERR TV CMD...: run CMD under timeout and /usr/bin/time -v;
# sets RC to the exit status (124: timeout). (Not in a subshell: cleanup must
# see $child, as `timeout` runs in a process group of its own.)
run_timed() {
  local out="$1" err="$2" tv="$3"; shift 3
  RC=0
  timeout "$TIMEOUT" /usr/bin/time -v -o "$tv" "$@" </dev/null >"$out" 2>"$err" &
  child=$!
  wait "$child" || RC=$?
  child=""
}

rss_mib() { awk -F': ' '/Maximum resident set size/ { printf "%.1f", $2 / 1024 }' "$1"; }

# --- per-case setup: isoray command and expected output -----------------------

# setup_isoray CASE: sets ISO_CMD (array), EXPECT (file: normalized expected
# output, or empty when there is none), CMP (lines|terms), LEGEND.
setup_isoray() {
  local c="$1"
  ISO_CMD=() EXPECT="" CMP=lines LEGEND=""
  case "$c" in
    startup)
      ISO_CMD=("$ISORAY" groebner --vars x --order grevlex --stats x)
      LEGEND="(start-up): trivial input: isoray \`groebner --vars x x\`, Singular \`R = I\` (timing.sh \`startup\`)" ;;
    katsura-* | cyclic-*)
      local f vars order
      f="$(reference_file "$c")" || return 1
      read -r _ _ vars _ order < <(head -n1 "$f")
      if [ "$order" != grevlex ]; then
        echo "algebra: $f: order $order, expected grevlex" >&2; return 1
      fi
      sed -n 's/^#   //p' "$f" >"$TMP/$c.in"
      sed -n '/^# basis:/,$p' "$f" | sed '1d; /^#/d; /^[[:space:]]*$/d' | nospace | sort >"$TMP/$c.expect"
      ISO_CMD=("$ISORAY" groebner --vars "$vars" --order grevlex --input "$TMP/$c.in" --stats)
      EXPECT="$TMP/$c.expect"
      [ "$f" = "$DATA/$c.txt" ] || LEGEND="$c: input and reference basis computed by Singular in this run (no $DATA/$c.txt)" ;;
    implicit-*)
      local i="${c#implicit-}" line lhs ax ay az
      line="$(sed -n "${i}p" "$DATA/implicit.txt")"
      [ -n "$line" ] || { echo "algebra: no line $i in $DATA/implicit.txt" >&2; return 1; }
      lhs="${line%% => *}"
      IFS=';' read -r ax ay az <<<"$lhs"
      ax="$(nospace <<<"$ax")"; ay="$(nospace <<<"$ay")"; az="$(nospace <<<"$az")"
      if [ "${ax:0:2}" != "x=" ] || [ "${ay:0:2}" != "y=" ] || [ "${az:0:2}" != "z=" ]; then
        echo "algebra: cannot parse line $i of $DATA/implicit.txt: $line" >&2; return 1
      fi
      ISO_CMD=("$ISORAY" implicitize --x "${ax:2}" --y "${ay:2}" --z "${az:2}" --stats)
      terms <<<"${line#* => }" >"$TMP/$c.expect"
      EXPECT="$TMP/$c.expect" CMP=terms
      LEGEND="$c: $lhs  =>  ${line#* => }" ;;
  esac
}

# --- main loop ----------------------------------------------------------------

LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
DATE=$(date -u '+%Y-%m-%d %H:%M:%S UTC')
ROWS=()
LEGENDS=()
for c in "${cases[@]}"; do
  setup_isoray "$c" || { ROWS+=("| $c | error | | | | | setup failed |"); continue; }
  [ -z "$LEGEND" ] || LEGENDS+=("$LEGEND")
  iso_ms=() iso_rss=() sing_ms=() sing_rss=()
  iso_bad="" sing_bad="" match=""
  [ -n "$EXPECT" ] || match="—"
  for ((r = 1; r <= REPS; r++)); do
    echo "algebra: $c run $r/$REPS: isoray" >&2
    out="$TMP/iso.out" err="$TMP/iso.err" tv="$TMP/iso.time"
    run_timed "$out" "$err" "$tv" "${ISO_CMD[@]}"
    rc=$RC
    if [ "$rc" -eq 124 ]; then
      iso_bad="timeout (>${TIMEOUT} s)"
    elif [ "$rc" -ne 0 ] || ! grep -q '^time: ' "$err"; then
      echo "algebra: isoray failed on $c (rc $rc):" >&2; tail -n 20 "$err" >&2
      iso_bad="error (rc $rc)"
    else
      iso_ms+=("$(awk '/^time: / { printf "%.3f", $2 * 1000 }' "$err")")
      iso_rss+=("$(rss_mib "$tv")")
      if [ -n "$EXPECT" ]; then
        if [ "$CMP" = terms ]; then terms <"$out" >"$TMP/iso.norm"; else nospace <"$out" | sed '/^$/d' | sort >"$TMP/iso.norm"; fi
        if cmp -s "$TMP/iso.norm" "$EXPECT"; then
          [ -n "$match" ] || match="yes"
        else
          match="**NO**"
          echo "algebra: isoray's result for $c differs from the reference:" >&2
          diff "$EXPECT" "$TMP/iso.norm" | head -n 10 >&2 || true
        fi
      fi
    fi

    echo "algebra: $c run $r/$REPS: Singular" >&2
    srow=""
    if srow="$(TIMEOUT="$TIMEOUT" MIN_MS="$MIN_MS" "$SING_DIR/timing.sh" "$c" | grep '^| ' | tail -n1)" \
      && [ -n "$srow" ]; then
      # | case | wall ms | CPU ms | runs | peak RSS MiB | memory(2) MiB |
      # (the case name of an implicit case contains no `|`)
      sw="$(awk -F'|' '{ gsub(/ /, "", $3); print $3 }' <<<"$srow")"
      sr="$(awk -F'|' '{ gsub(/ /, "", $6); print $6 }' <<<"$srow")"
      case "$sw" in
        timeout*) sing_bad="timeout (>${TIMEOUT} s)" ;;
        error* | '') sing_bad="error" ;;
        *) sing_ms+=("$sw"); sing_rss+=("$sr") ;;
      esac
    else
      echo "algebra: timing.sh failed on $c" >&2
      sing_bad="error"
    fi
  done

  if [ -n "$iso_bad" ]; then
    im="$iso_bad" irss=""
  else
    im="$(median '%.3f' "${iso_ms[@]}")" irss="$(median '%.1f' "${iso_rss[@]}")"
  fi
  if [ -n "$sing_bad" ]; then
    sm="$sing_bad" srss=""
  else
    sm="$(median '%.3f' "${sing_ms[@]}")" srss="$(median '%.1f' "${sing_rss[@]}")"
  fi
  ratio=""
  if [ "$c" = startup ]; then
    ratio="—"
  elif [ -z "$iso_bad" ] && [ -z "$sing_bad" ]; then
    ratio="$(awk -v a="$im" -v b="$sm" 'BEGIN {
      if (b <= 0) print "n/a";
      else if (a <= 0) printf "< %.2g", 0.001 / b;
      else printf "%.2f", a / b }')"
  fi
  # isoray prints its time in microseconds
  [ -n "$iso_bad" ] || im="$(awk -v a="$im" 'BEGIN { if (a >= 10) printf "%.0f", a; else printf "%.3f", a }')"
  [ -n "$iso_bad" ] || [ -n "$match" ] || match="?"
  name="$c"; [ "$c" = startup ] && name="(start-up)"
  ROWS+=("| $name | $im | $sm | $ratio | $irss | $srss | $match |")
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)

# --- report -------------------------------------------------------------------

commit="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
if [ -n "$(git status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  commit+=" (plus uncommitted changes to: $(git status --porcelain --untracked-files=no | awk '{ print $2 }' | tr '\n' ' ' | sed 's/ $//'))"
fi
model="$(lscpu | sed -n 's/^Model name:[[:space:]]*//p' | head -n1)"
report() {
  echo "## isoray vs Singular: Groebner bases and implicitization"
  echo
  echo "- Date: $DATE"
  echo "- Commit: $commit"
  echo "- Command: \`$CMDLINE\`"
  echo "- Machine: $model, nproc $(nproc)"
  echo "- Load average (1/5/15 min): before $LOAD_BEFORE, after $LOAD_AFTER"
  echo "- isoray: $("$ISORAY" --version 2>&1 | head -n1), $(rustc --version 2>/dev/null || echo 'rustc ?')"
  echo "- Singular: $(Singular --version 2>&1 | head -n1)"
  echo
  echo "Medians of $REPS runs per tool, run alternately (isoray, Singular, isoray, ...), one process each."
  echo "Times are measured inside each program, excluding start-up and parsing: isoray's \`--stats\` \`time:\` (1 µs resolution),"
  echo "Singular's rtimer around \`std\`/\`eliminate\` (bench/singular/timing.sh, MIN_MS=$MIN_MS$([ "$MIN_MS" -gt 0 ] && echo ': mean of a batch of repeated runs' || echo ': one computation per process'))."
  echo "Peak RSS: whole process (start-up included), from \`/usr/bin/time -v\`."
  echo "Gröbner cases: reduced basis over Q, grevlex. Match: isoray's output vs crates/isoray-algebra/tests/data (Singular's result)."
  echo
  echo "| case | isoray ms | Singular ms | isoray / Singular | isoray peak RSS MiB | Singular peak RSS MiB | isoray result matches reference |"
  echo "|---|---:|---:|---:|---:|---:|:---:|"
  printf '%s\n' "${ROWS[@]}"
  if [ ${#LEGENDS[@]} -gt 0 ]; then
    echo
    printf -- '- %s\n' "${LEGENDS[@]}"
  fi
}
report | tee bench/out/algebra.md
echo "algebra: wrote bench/out/algebra.md" >&2
