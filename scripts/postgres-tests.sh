#!/usr/bin/env bash
# The PostgreSQL tests of the history store and the CLI against a real, throw-away server.
#
#   scripts/postgres-tests.sh            run the tests (`cargo test ... -- --ignored postgres`)
#   scripts/postgres-tests.sh --bench    run the PostgreSQL store benchmark instead
#   scripts/postgres-tests.sh -- CMD...  run CMD with FEEDSCOPE_TEST_POSTGRES (and
#                                        FEEDSCOPE_TEST_POSTGRES_RESTART) set
#
# Starts a PostgreSQL server (initdb into a temporary folder, listening on 127.0.0.1 only on
# a free port, its Unix socket in the same folder, trust authentication for the loopback),
# creates a database, exports FEEDSCOPE_TEST_POSTGRES=postgres://USER@127.0.0.1:PORT/DB, runs
# the tests (then, alone, the crash loop, which restarts the server through the script in
# FEEDSCOPE_TEST_POSTGRES_RESTART), then stops the server and removes everything (also on
# failure or Ctrl-C).
#
# PostgreSQL refuses to run as root: as root the server runs as the `postgres` system user
# that the Debian package creates (via runuser or setpriv). On a machine without PostgreSQL it
# is installed with apt-get (Debian/Ubuntu).
set -euo pipefail
cd "$(dirname "$0")/.."

mode=test
if [ "${1:-}" = "--bench" ]; then
    mode=bench
    shift
elif [ "${1:-}" = "--" ]; then
    mode=command
    shift
fi

find_bin() {
    local d
    for d in /usr/lib/postgresql/*/bin; do
        if [ -x "$d/initdb" ]; then
            echo "$d"
        fi
    done | sort -V | tail -n 1
}

pgbin=$(find_bin)
if [ -z "$pgbin" ]; then
    if [ "$(id -u)" = 0 ]; then sudo=""; else sudo="sudo"; fi
    echo "== installing PostgreSQL (apt-get)" >&2
    $sudo apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq postgresql >/dev/null
    pgbin=$(find_bin)
    if [ -z "$pgbin" ]; then
        echo "PostgreSQL's initdb not found after installing the postgresql package" >&2
        exit 1
    fi
fi

# As root: the server runs as `postgres`; otherwise as the current user.
if [ "$(id -u)" = 0 ]; then
    pguser=postgres
    if ! id "$pguser" >/dev/null 2>&1; then
        echo "running as root and there is no 'postgres' user to run the server as" >&2
        exit 1
    fi
    if command -v runuser >/dev/null 2>&1; then
        as_pg() { runuser -u "$pguser" -- "$@"; }
    else
        as_pg() {
            setpriv --reuid="$pguser" --regid="$(id -g "$pguser")" --init-groups -- "$@"
        }
    fi
else
    pguser=$(id -un)
    as_pg() { "$@"; }
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/feedscope-pg.XXXXXX")
chmod 755 "$tmp"
data="$tmp/data"
mkdir "$data"
if [ "$(id -u)" = 0 ]; then
    chown "$pguser" "$tmp" "$data"
fi
started=no
cleanup() {
    local rc=$?
    if [ "$started" = yes ]; then
        as_pg "$pgbin/pg_ctl" -D "$data" -m immediate -w stop >/dev/null 2>&1 || true
    fi
    rm -rf "$tmp"
    exit "$rc"
}
trap cleanup EXIT INT TERM

# A free port: bind port 0 and read what the kernel gave (a small race with other programs
# picking the same port in the next milliseconds; pg_ctl then fails loudly).
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')

echo "== PostgreSQL $("$pgbin/postgres" --version | awk '{print $3}') on 127.0.0.1:$port ($tmp)" >&2
as_pg "$pgbin/initdb" -D "$data" -U "$pguser" --auth=trust --encoding=UTF8 --locale=C.UTF-8 \
    >"$tmp/initdb.log" 2>&1 || { cat "$tmp/initdb.log" >&2; exit 1; }
# Tests: no fsync (a killed client, not a crashed machine, is what they exercise; the
# throw-away cluster is deleted anyway). The benchmark runs with the defaults (fsync on).
opts="-c listen_addresses=127.0.0.1 -c port=$port -c unix_socket_directories=$tmp -c max_connections=200"
if [ "$mode" != bench ]; then
    opts="$opts -c fsync=off -c full_page_writes=off"
fi
started=yes
as_pg "$pgbin/pg_ctl" -D "$data" -l "$tmp/server.log" -o "$opts" -w start >/dev/null \
    || { cat "$tmp/server.log" >&2; exit 1; }
as_pg "$pgbin/createdb" -h 127.0.0.1 -p "$port" -U "$pguser" feedscope_test

export FEEDSCOPE_TEST_POSTGRES="postgres://$pguser@127.0.0.1:$port/feedscope_test"
echo "== FEEDSCOPE_TEST_POSTGRES=$FEEDSCOPE_TEST_POSTGRES" >&2

# A server crash and restart for the crash-loop test: an immediate stop (no shutdown
# checkpoint, sessions cut off as by a crash), then a start that waits until the server
# accepts connections again (after its crash recovery).
restart="$tmp/restart-server"
if [ "$(id -u)" = 0 ]; then
    prefix="$(printf '%q ' runuser -u "$pguser" --)"
    command -v runuser >/dev/null 2>&1 \
        || prefix="$(printf '%q ' setpriv --reuid="$pguser" --regid="$(id -g "$pguser")" --init-groups --)"
else
    prefix=""
fi
{
    echo '#!/usr/bin/env bash'
    echo 'set -e'
    echo "$prefix$(printf '%q ' "$pgbin/pg_ctl" -D "$data" -m immediate -w stop) >/dev/null"
    echo "$prefix$(printf '%q ' "$pgbin/pg_ctl" -D "$data" -l "$tmp/server.log" -o "$opts" -w start) >/dev/null"
} >"$restart"
chmod 755 "$restart"
export FEEDSCOPE_TEST_POSTGRES_RESTART="$restart"

case "$mode" in
test)
    # The PostgreSQL tests are #[ignore]d in a plain `cargo test` (they need this server);
    # `--ignored postgres` runs those whose name contains "postgres". The crash loop restarts
    # the server, so it runs alone, after the others; it prints the adds' outcomes.
    # `--workspace --tests` selects what the README's test command builds, so nothing is built
    # again with other dependency features (.ci/run); the name filter picks the tests.
    cargo test --workspace --tests --release --locked -- --ignored postgres \
        --skip postgres_server_crash_loop
    cargo test --workspace --release --locked --test cli -- --ignored --exact \
        postgres::postgres_server_crash_loop_during_adds --nocapture
    ;;
bench)
    cargo bench --locked -p feedscope-store --bench postgres -- "$@"
    ;;
command)
    "$@"
    ;;
esac
