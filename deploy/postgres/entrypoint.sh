#!/bin/sh
# First start: a cluster in $PGDATA with the superuser "excite", its password
# from $POSTGRES_PASSWORD_FILE (a mounted secret) or $POSTGRES_PASSWORD, SCRAM
# authentication over TCP, and a database "excite". Then the server itself.
set -eu
if [ ! -s "$PGDATA/PG_VERSION" ]; then
  pwfile=$(mktemp)
  if [ -n "${POSTGRES_PASSWORD_FILE:-}" ]; then
    cat "$POSTGRES_PASSWORD_FILE" > "$pwfile"
  elif [ -n "${POSTGRES_PASSWORD:-}" ]; then
    printf '%s\n' "$POSTGRES_PASSWORD" > "$pwfile"
  else
    echo "excite-postgres: set POSTGRES_PASSWORD_FILE or POSTGRES_PASSWORD" >&2
    exit 2
  fi
  initdb -D "$PGDATA" -U excite --pwfile="$pwfile" --auth-local=trust \
    --auth-host=scram-sha-256 -E UTF8 --locale=C.UTF-8
  rm -f "$pwfile"
  echo "host all all 0.0.0.0/0 scram-sha-256" >> "$PGDATA/pg_hba.conf"
  echo "host all all ::/0 scram-sha-256" >> "$PGDATA/pg_hba.conf"
  echo "CREATE DATABASE excite" | postgres --single -D "$PGDATA" postgres > /dev/null
fi
exec postgres -D "$PGDATA" -c listen_addresses='*' -c unix_socket_directories=/var/run/postgresql
