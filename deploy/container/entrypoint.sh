#!/bin/sh
# Container entrypoint: reads the same /etc/impostor/*.conf files as the
# systemd units (deploy/debian/server.conf, worker.conf) and runs the binary
# in the foreground. Extra arguments are passed on as flags.
#   impostor-entrypoint server [FLAGS...]
#   impostor-entrypoint worker [FLAGS...]
set -eu
role=${1:?usage: impostor-entrypoint server|worker [FLAGS...]}
shift
case "$role" in
  server)
    if [ -f /etc/impostor/server.conf ]; then . /etc/impostor/server.conf; fi
    # IMPOSTOR_DATA is the server's own directory in every case (--data is
    # required: local workers' socket and state; on one machine also SQLite
    # and DATA/cas). Several replicas (issue 15) add IMPOSTOR_DATABASE (a
    # postgresql:// URL) and IMPOSTOR_BLOB_DIR (a shared filesystem).
    store="--data=${IMPOSTOR_DATA:-/var/lib/impostor}"
    if [ -n "${IMPOSTOR_DATABASE:-}" ]; then
      store="$store --database=$IMPOSTOR_DATABASE --blob-dir=${IMPOSTOR_BLOB_DIR:-/var/lib/impostor/cas}"
    fi
    # The flags are split on spaces on purpose (as in the systemd unit).
    # shellcheck disable=SC2086
    exec /usr/bin/impostor-server --listen="${IMPOSTOR_LISTEN:-0.0.0.0:50051}" $store \
      ${IMPOSTOR_SERVER_FLAGS:-} "$@"
    ;;
  worker)
    if [ -f /etc/impostor/worker.conf ]; then . /etc/impostor/worker.conf; fi
    # shellcheck disable=SC2086
    exec /usr/bin/impostor-worker --server="${IMPOSTOR_SERVER:-localhost:50051}" \
      ${IMPOSTOR_VK_DEVICE:+--device="$IMPOSTOR_VK_DEVICE"} ${IMPOSTOR_WORKER_FLAGS:-} "$@"
    ;;
  *)
    echo "impostor-entrypoint: unknown role \"$role\" (want server or worker)" >&2
    exit 2
    ;;
esac
