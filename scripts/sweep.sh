#!/bin/bash
# Long study sweeps across sessions and machines (docs/studies.md, "Sweeps across sessions").
#
# A sweep runs from its own clone of this repository's committed HEAD (a clone, not a worktree:
# the Debian 13 root that runs YADE 2025.2 bind-mounts the tree and needs its .git), so edits here
# never touch runs in flight, and every record carries a clean commit.  Its finished records are
# copied back with `collect` and committed; `start` on any machine resumes from what is committed.
#
#   scripts/sweep.sh start SPEC [DIR]     refresh DIR to HEAD (keeping its finished records), set it
#                                         up, and start the sweep in the background (log: DIR/sweep.log)
#   scripts/sweep.sh refresh SPEC [DIR]   only the first step
#   scripts/sweep.sh collect SPEC [DIR]   copy DIR's finished records (never over one already here)
#                                         and its manifest into this tree, to commit
#   scripts/sweep.sh stop SPEC            stop this machine's sweeps of SPEC (their YADE runs die with
#                                         them; a run in flight is lost and runs again next time), and
#                                         any queue that holds SPEC, first
#   scripts/sweep.sh drain SPEC [DIR]     let DIR's sweep of SPEC finish the runs in flight, start no
#                                         more, and end (nothing lost; any queue that holds SPEC
#                                         ends first); then `wait`, `collect`.  BY=HH:MM: a deadline;
#                                         until then only runs expected to finish by it start
#   scripts/sweep.sh wait SPEC [DIR]      return when no sweep of SPEC runs in DIR
#   scripts/sweep.sh queue SPEC [SPEC...] in the background: start each SPEC when the one before it
#                                         ends (met its targets or spent its budget), so
#                                         no core idles (log: ../sweep-queue.log beside this repository)
#
# SPEC: a spec name (studies/specs/SPEC.toml).  DIR: default ../sweep-SPEC beside this repository.
# WORKERS (default 1): Dask workers of the sweep, one YADE run each.
set -euo pipefail
usage() { sed -n '9,27p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[ $# -ge 2 ] || usage
cmd=$1
name=$(basename "$2" .toml)
root=$(cd "$(dirname "$0")/.." && pwd)
dir=${3:-$root/../sweep-$name}
specfile=studies/specs/$name.toml
[ -f "$root/$specfile" ] || { echo "[sweep] no spec $specfile" >&2; exit 2; }
results=$(sed -n 's/^results *= *"\([^"]*\)".*/\1/p' "$root/$specfile" | head -n 1)
yade=$(sed -n 's/^yade *= *"\([^"]*\)".*/\1/p' "$root/$specfile" | head -n 1)
[ -n "$results" ] || { echo "[sweep] $specfile has no study.results" >&2; exit 2; }

# a driver holds an flock on its results' .driver.lock while it runs (studies.engine.sweep)
running() { [ -f "$dir/$results/.driver.lock" ] && ! flock -n "$dir/$results/.driver.lock" true; }

refresh() {
    if [ ! -d "$dir/.git" ]; then
        git clone -q "$root" "$dir"
        echo "[sweep] cloned $root into $dir"
    fi
    local keep
    # a refresh killed midway (stop during a queue's start) leaves git's lock: nothing else works here
    rm -f "$dir/.git/index.lock"
    keep=$(mktemp -d)
    cp -p "$dir/$results/runs/"*.json "$keep/" 2>/dev/null || true
    git -C "$dir" fetch -q "$root" HEAD
    git -C "$dir" checkout -q --detach FETCH_HEAD 2>/dev/null || {
        git -C "$dir" reset -q --hard
        git -C "$dir" clean -fdq -- "$results"
        git -C "$dir" checkout -q --detach FETCH_HEAD
    }
    git -C "$dir" reset -q --hard
    mkdir -p "$dir/$results/runs"
    cp -np "$keep/"*.json "$dir/$results/runs/" 2>/dev/null || true
    rm -rf "$keep"
    echo "[sweep] $dir at $(git -C "$dir" rev-parse --short HEAD), $(ls "$dir/$results/runs" | wc -l) finished records of $name"
}

# first any queue holding SPEC (its whole process group: it would start the next spec)
end_queues() {
    for pid in $(pgrep -f "sweep\.sh _queue" || true); do
        q=$(tr '\0' '\n' < "/proc/$pid/cmdline" 2>/dev/null | sed '1,/^_queue$/d' || true)
        if grep -qxF "$name" <<< "$q"; then
            kill -- "-$pid" 2>/dev/null || kill "$pid" 2>/dev/null || true
            echo "[sweep] ended the queue of" $q
        fi
    done
}

case $cmd in
    refresh)
        running && { echo "[sweep] a sweep of $name is running in $dir: stop it first" >&2; exit 1; }
        refresh ;;
    start)
        running && { echo "[sweep] a sweep of $name is already running in $dir" >&2; exit 1; }
        refresh
        (cd "$dir" && VENV=.venv bash scripts/setup.sh >/dev/null)
        if [ "$yade" != "2023.02a" ]; then
            (cd "$dir" && bash scripts/debian13.sh build >/dev/null &&
                bash scripts/debian13.sh run env VENV=.venv-debian13 bash scripts/setup.sh >/dev/null)
        fi
        cd "$dir"
        OMP_NUM_THREADS=1 nohup setsid nice -n 10 .venv/bin/python -m studies sweep "$specfile" \
            --workers "${WORKERS:-1}" --progress-every 300 > sweep.log 2>&1 < /dev/null &
        pid=$!
        # return once the driver holds its lock (or has ended): `wait` after `start` then never
        # returns before the sweep has begun
        for _ in $(seq 600); do running && break; kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        echo "[sweep] started $name in $dir (log: $dir/sweep.log)" ;;
    collect)
        [ -d "$dir/$results/runs" ] || { echo "[sweep] no records in $dir/$results/runs" >&2; exit 1; }
        mkdir -p "$root/$results/runs"
        n=0
        for f in "$dir/$results/runs/"*.json; do
            [ -e "$f" ] || continue
            t="$root/$results/runs/$(basename "$f")"
            [ -e "$t" ] || { cp -p "$f" "$t"; n=$((n + 1)); }
        done
        [ -f "$dir/$results/manifest.csv" ] && cp -p "$dir/$results/manifest.csv" "$root/$results/manifest.csv"
        echo "[sweep] $n new records of $name in $results/runs" ;;
    wait)
        while running; do sleep "${SWEEP_POLL:-30}"; done ;;
    queue)
        shift
        names=()
        for s in "$@"; do
            s=$(basename "$s" .toml)
            [ -f "$root/studies/specs/$s.toml" ] || { echo "[sweep] no spec studies/specs/$s.toml" >&2; exit 2; }
            names+=("$s")
        done
        log=$(cd "$root/.." && pwd)/sweep-queue.log
        nohup setsid bash "$0" _queue "${names[@]}" >> "$log" 2>&1 < /dev/null &
        echo "[sweep] queued ${names[*]} (each starts when the one before it ends; log: $log; stop SPEC ends the queue too)" ;;
    _queue)                                     # the queue itself, in its own session (see stop)
        shift
        for s in "$@"; do                       # spec names (queue passes them)
            echo "[queue] $(date -u '+%F %T') UTC: $s"
            bash "$0" start "$s" || echo "[queue] $s did not start (above); waiting for any sweep of it"
            bash "$0" wait "$s"
        done
        echo "[queue] $(date -u '+%F %T') UTC: done" ;;
    stop)
        end_queues
        pkill -f "studies sweep $specfile" && echo "[sweep] stopped $name" || echo "[sweep] no sweep of $name running" ;;
    drain)
        if [ -n "${BY:-}" ]; then               # checked before anything is ended
            by=$(date -d "$BY" +%s 2>/dev/null) || { echo "[sweep] BY=$BY: not a time date -d reads (e.g. 20:05, \"+40 min\")" >&2; exit 2; }
            [ "$by" -gt "$(date +%s)" ] || { echo "[sweep] BY=$BY is past (a bare HH:MM is today's)" >&2; exit 2; }
        fi
        end_queues
        # a driver the queue has just launched may not hold its lock yet: give it the time start gives it
        for _ in $(seq 600); do
            running && break
            pgrep -f "studies sweep $specfile" > /dev/null || break
            sleep 0.1
        done
        if running; then
            if [ -n "${BY:-}" ]; then           # a deadline: until then only runs expected to finish by it start
                echo "$by" > "$dir/$results/.drain.tmp" && mv "$dir/$results/.drain.tmp" "$dir/$results/.drain"
                echo "[sweep] draining $name in $dir by $(date -u -d "@$by" '+%H:%M UTC'): until then only runs expected to finish by it start; then as drain (then: wait, collect)"
            else
                : > "$dir/$results/.drain"      # studies.engine.DRAIN, empty: now (also over an earlier BY=)
                echo "[sweep] draining $name in $dir: the runs in flight finish, no new run starts (then: wait, collect)"
            fi
        else
            echo "[sweep] no sweep of $name running in $dir"
        fi ;;
    *) usage ;;
esac
