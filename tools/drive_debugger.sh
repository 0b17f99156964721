#!/usr/bin/env bash
# Drive `netsushisen debug` in a real terminal (tmux) and capture what the user sees.
#
#   tools/drive_debugger.sh [OUT.txt]      (default: debugger-screens.txt in the current folder)
#
# Writes the demo pipeline of docs/debugger.md (OS -> IC -> SC -> COL, one PE) into a temporary
# folder, starts the debugger in a detached tmux session of DRIVE_SIZE (default 150x50; the
# screen is laid out for the size, docs/debugger.md), types commands with
# `tmux send-keys` (breakpoint, continue, Enter to repeat, stepi, print, x, watch, reverse-cycle,
# Tab completion, a bad command) and appends each screen, captured with `tmux capture-pane`, to
# OUT. Exit 0 when every step showed what it should, 1 otherwise. Needs tmux (apt-get install
# tmux). PYTHON picks the interpreter that runs `python -m netsushisen.cli` (tests pass their
# own, sys.executable); without it, `netsushisen` from PATH, else python3. DRIVE_QUICK=1
# captures fewer screens.
set -euo pipefail

OUT=${1:-debugger-screens.txt}
SIZE=${DRIVE_SIZE:-150x50}
COLS=${SIZE%x*}
ROWS=${SIZE#*x}
PY=${PYTHON:-python3}
HERE=$(cd "$(dirname "$0")/.." && pwd)
WORK=$(mktemp -d)
SESSION="nssdbg$$"  # also its own tmux server (-L): runs side by side never share a server's sizes
trap 'tmux -L "$SESSION" kill-server 2>/dev/null || true; rm -rf "$WORK"' EXIT

command -v tmux >/dev/null || { echo "drive_debugger: tmux is not installed" >&2; exit 1; }

cat > "$WORK/os.s" <<'EOF'
.proc os
loop:   recv r1, host                       # header from DIS
        recv r2, host                       # pixel index
        li r3, (DEST_IC << HDR_DEST_SHIFT) | 1
        send ring, r3
        send ring, r2
        j loop
EOF
cat > "$WORK/ic.s" <<'EOF'
.proc ic
.reg pix = r2
.reg shape = r4
.reg sum = r6
loop:   recv r1, ring                       # header
        recv pix, ring                      # pixel index
        slli r3, pix, 2                     # 4 words per pixel
        { ldg shape, [r3 + 1] ; lf r8, 0.5 }   # shape word, through the cache
        ldr r5, [pix]                       # resident word
        { fadd sum, shape, r5 ; fmul r9, shape, r8 }
        li r7, (DEST_SC << HDR_DEST_SHIFT) | (1 << HDR_CLS_SHIFT) | 2
        send ring, r7
        send ring, pix
        send ring, sum
        j loop
EOF
cat > "$WORK/sc.s" <<'EOF'
.proc sc
        li r5, (DEST_COL << HDR_DEST_SHIFT) | 4
        lf r8, 0.5
loop:   recv r1, ring
        recv r2, ring
        recv r3, ring
        itof r4, r2
        send col, r5
        send col, r2
        send col, r3
        send col, r4
        send col, r8
        j loop
EOF
"$PY" - "$WORK/image.json" <<'EOF'
import json, sys
host = []
for i in range(6):
    host += [{"header": {"length": 1, "dest": "os"}}, i]
json.dump({"host": host, "frame": {"width": 3, "height": 2},
           "icgm": [float(i) for i in range(32)], "ic.resident": [0.25 * i for i in range(6)]},
          open(sys.argv[1], "w"))
EOF

# `netsushisen` if it is installed, else the module
if command -v netsushisen >/dev/null && [ -z "${PYTHON:-}" ]; then
    NSS="netsushisen"
else
    NSS="$PY -m netsushisen.cli"
fi

: > "$OUT"
tmux -L "$SESSION" new-session -d -s "$SESSION" -x "$COLS" -y "$ROWS" \
    "unset COLUMNS LINES; cd '$WORK' && PYTHONPATH='${PYTHONPATH:-}' NETSUSHISEN_DEBUG_HISTORY='' $NSS debug --os os.s --ic ic.s --sc sc.s --image image.json --proc ic; echo '[debugger exited]'; sleep 30"

screen() { tmux -L "$SESSION" capture-pane -p -t "$SESSION"; }

# wait until the screen has changed from $2 (if given) and the prompt is back (the last
# non-empty line is `(nss)`), at most ~90 s (a loaded machine starts the debugger slowly)
wait_prompt() {
    local before=${2:-}
    for _ in $(seq 1 900); do
        local now
        now=$(screen)
        if [ "$now" != "$before" ] && printf '%s\n' "$now" | grep -v '^\s*$' | tail -n 1 | grep -q '^(nss) *$'; then
            return 0
        fi
        sleep 0.1
    done
    echo "drive_debugger: no prompt after: $1" >&2
    screen >&2
    return 1
}

FAILED=0
# type a command (literally), Enter, wait, append the screen to OUT (when $3 is 1, under the
# title $4), check the screen shows $2
step() {
    local cmd=$1 expect=${2:-} keep=${3:-1} title=${4:-$1}
    if [ -n "$cmd" ]; then
        tmux -L "$SESSION" send-keys -t "$SESSION" -l "$cmd"
    fi
    sleep 0.1
    local before
    before=$(screen)
    tmux -L "$SESSION" send-keys -t "$SESSION" Enter
    wait_prompt "$cmd" "$before"
    if [ "$keep" = 1 ]; then
        { echo "===== (nss) ${title:-<Enter> (repeats the last command)}"; screen | sed -e 's/[[:space:]]*$//'; echo; } >> "$OUT"
    fi
    if [ -n "$expect" ] && ! screen | grep -qF -- "$expect"; then
        echo "drive_debugger: after '${cmd:-<Enter>}' the screen does not show: $expect" >&2
        FAILED=1
    fi
}

QUICK=${DRIVE_QUICK:-0}
wait_prompt "start"
{ echo "===== start"; screen | sed -e 's/[[:space:]]*$//'; echo; } >> "$OUT"
step "break loop+5"      "breakpoint 1 at ic pc 5"            "$((1 - QUICK))"
step "continue"          "breakpoint 1: pe0.ic issued pc 5 (loop+5)"
# at every size: the register names in the registers panel, the current bundle's operands whole
for want in "*shape/r4" "fadd sum/r6, shape/r4, r5" "fmul r9, shape/r4, r8"; do
    screen | grep -qF -- "$want" || { echo "drive_debugger: the stop does not show: $want" >&2; FAILED=1; }
done
step ""                  "breakpoint 1: pe0.ic issued pc 5 (loop+5)" "$((1 - QUICK))"
step "stepi"             "issued pc 6"                         "$((1 - QUICK))"
step "print f:sum"       "f:sum/r6 = "                         0
step "x/4f icgm 0"       "icgm[0]:"                            0
step "watch sum"         "watchpoint 2 on pe0.ic.sum/r6"       0
step "continue"          "watchpoint 2: pe0.ic.sum/r6:"
step "reverse-cycle 12"  "last cycle 22 (23 cycles run)"      "$((1 - QUICK))"
step "bogus"             "error: unknown command 'bogus'"      0
step "help"              "Type \"help\" followed by a command name" 0
# `help all` is longer than a short terminal: gdb's pager asks before each further page
tmux -L "$SESSION" send-keys -t "$SESSION" -l "help all"
tmux -L "$SESSION" send-keys -t "$SESSION" Enter
if [ "$ROWS" -lt 45 ]; then
    for _ in $(seq 1 100); do
        screen | grep -qF -- "--Type <RET> for more" && break
        sleep 0.1
    done
    { echo "===== (nss) help all"; screen | sed -e 's/[[:space:]]*$//'; echo; } >> "$OUT"
    screen | grep -qF -- "--Type <RET> for more, q to quit, c to continue without paging--" \
        || { echo "drive_debugger: help all was not paged" >&2; FAILED=1; }
    before=$(screen)
    tmux -L "$SESSION" send-keys -t "$SESSION" -l "q"
    tmux -L "$SESSION" send-keys -t "$SESSION" Enter
    wait_prompt "q (leave the pager)" "$before"
else
    wait_prompt "help all"
    if [ "$ROWS" -ge 50 ] && screen | grep -qF -- "--Type <RET>"; then
        echo "drive_debugger: help all paged on a tall terminal" >&2; FAILED=1
    fi
fi
# Tab completion: `info reg<Tab>` completes to `info registers`
tmux -L "$SESSION" send-keys -t "$SESSION" -l "info reg"
tmux -L "$SESSION" send-keys -t "$SESSION" Tab
for _ in $(seq 1 100); do  # the completion is drawn when the front end gets to it
    screen | grep -q "(nss) info registers" && break
    sleep 0.1
done
# 64 registers in one column on a short terminal: the pager asks; `c` shows the rest (lr last)
if [ "$ROWS" -ge 45 ]; then
    step "" "registers pe0.ic (* changed since the previous stop)" "$((1 - QUICK))" \
        "info reg<Tab> (completes to: info registers)"
else
    before=$(screen)
    tmux -L "$SESSION" send-keys -t "$SESSION" Enter
    last() { screen | grep -v '^\s*$' | tail -n 1; }
    for _ in $(seq 1 100); do
        [ "$(screen)" != "$before" ] && last | grep -qE -- '^(--Type <RET>|\(nss\) *$)' && break
        sleep 0.1
    done
    if last | grep -qF -- "--Type <RET> for more"; then
        step "c" "lr " "$((1 - QUICK))" "info reg<Tab> (completes to: info registers), c at the pager"
    elif [ "$ROWS" -lt 30 ]; then
        echo "drive_debugger: info registers was not paged" >&2; FAILED=1
    else
        screen | grep -qF "lr " || { echo "drive_debugger: info registers shows no lr" >&2; FAILED=1; }
    fi
fi
tmux -L "$SESSION" send-keys -t "$SESSION" -l "quit"
tmux -L "$SESSION" send-keys -t "$SESSION" Enter
for _ in $(seq 1 50); do
    screen | grep -q '\[debugger exited\]' && break
    sleep 0.1
done
screen | grep -q '\[debugger exited\]' || { echo "drive_debugger: quit did not exit" >&2; FAILED=1; }
echo "drive_debugger: screens in $OUT"
exit "$FAILED"
