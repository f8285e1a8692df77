#!/bin/sh
# Writes the authorization block of a nats-server configuration for Mimic (docs/security.md, The broker):
# one user per publisher, which may write only its own subjects and bucket keys, and relay users,
# which may only read the scenes (and ask publishers for mesh frames). No secret is written: each
# user's password is a reference to an environment variable of the nats-server process,
# MIMIC_NATS_PASSWORD_<USER> (the user name in capitals, anything but A-Z 0-9 as _), and the broker
# refuses to start when one is missing.
#
#   scripts/nats_auth_conf.sh [--scene S]... --publisher hostA --publisher hostB --relay relay > auth.conf
#
# A publisher's user name is its --nats-name (the token of its subjects and keys: A-Z a-z 0-9 _ -).
# With --scene, the users may use those scenes only; without, any scene (NATS wildcards match whole
# subject tokens, so "any scene" also means any JetStream stream and key-value bucket of the
# account: give Mimic a broker or an account of its own then).
# Include the output from the broker's configuration (config/nats/mimic-broker.conf does).
set -eu

publishers=""
relays=""
scenes=""
while [ $# -gt 0 ]; do
  case "$1" in
    --publisher) publishers="$publishers $2"; shift 2 ;;
    --relay) relays="$relays $2"; shift 2 ;;
    --scene) scenes="$scenes $2"; shift 2 ;;
    *) echo "usage: $0 [--scene S]... [--publisher NAME]... [--relay USER]..." >&2; exit 2 ;;
  esac
done

check_name() {
  case "$1" in
    ''|*[!A-Za-z0-9_-]*) echo "$0: '$1' is not a name of A-Z a-z 0-9 _ -" >&2; exit 2 ;;
  esac
  if [ ${#1} -gt 64 ]; then echo "$0: '$1' is longer than 64 characters" >&2; exit 2; fi
}
password_var() { printf 'MIMIC_NATS_PASSWORD_%s' "$(printf '%s' "$1" | tr 'a-z' 'A-Z' | tr -c 'A-Z0-9\n' '_')"; }

# Each pattern once per scene: @S@ the scene, @B@ its bucket (mimic_S), @T@ the bucket's stream
# (KV_mimic_S); without scenes, wildcards. Printed as a quoted, comma-separated list.
expand() {
  out=""
  for pattern in "$@"; do
    if [ -z "$scenes" ]; then
      item=$(printf '%s' "$pattern" | sed -e 's/@S@/*/g' -e 's/@B@/*/g' -e 's/@T@/*/g')
      out="$out${out:+, }\"$item\""
    else
      for s in $scenes; do
        item=$(printf '%s' "$pattern" | sed -e "s/@S@/$s/g" -e "s/@B@/mimic_$s/g" -e "s/@T@/KV_mimic_$s/g")
        out="$out${out:+, }\"$item\""
      done
    fi
  done
  printf '%s' "$out"
}

for s in $scenes; do check_name "$s"; done
relay_pub=$(expand 'mimic.@S@.want.>' '$JS.API.STREAM.NAMES' '$JS.API.STREAM.INFO.@T@' '$JS.API.STREAM.MSG.GET.@T@' '$JS.API.DIRECT.GET.@T@.>' \
  '$JS.API.CONSUMER.CREATE.@T@' '$JS.API.CONSUMER.CREATE.@T@.>' '$JS.API.CONSUMER.DELETE.@T@.*' '$JS.FC.@T@.>')
relay_sub=$(expand 'mimic.@S@.poses.*' 'mimic.@S@.status.*' 'mimic.@S@.mesh.>')

cat <<'HEAD'
# Mimic's broker users (written by scripts/nats_auth_conf.sh). Subjects of scene S, publisher P,
# avatar key K (docs/protocol.md, "Through a broker"):
#   mimic.S.poses.P  mimic.S.status.P  mimic.S.mesh.P.K.L   written by P only
#   mimic.S.want.P.K                                      written by relays, read by P
#   bucket mimic_S, key P.K  ($KV.mimic_S.P.K)            written (put, delete) by P only
# Anything not allowed below is refused by the broker (and logged as a permissions violation).
# JetStream API: publishers may look up and create the scene buckets, relays may look them up,
# read and watch them (an ordered consumer); nobody may delete, purge or reconfigure a bucket.
HEAD
printf 'MIMIC_RELAY_PERMISSIONS = {\n'
printf '  publish: { allow: [%s, "$JS.API.INFO"] }\n' "$relay_pub"
printf '  subscribe: { allow: [%s, "_INBOX.>"] }\n' "$relay_sub"
printf '}\n'
echo "authorization {"
echo "  users = ["
for r in $relays; do
  check_name "$r"
  printf '    { user: "%s", password: $%s, permissions: $MIMIC_RELAY_PERMISSIONS }\n' "$r" "$(password_var "$r")"
done
for p in $publishers; do
  check_name "$p"
  pub=$(expand "mimic.@S@.poses.$p" "mimic.@S@.status.$p" "mimic.@S@.mesh.$p.>" "\$KV.@B@.$p.>" \
    '$JS.API.STREAM.INFO.@T@' '$JS.API.STREAM.CREATE.@T@')
  sub=$(expand "mimic.@S@.want.$p.>")
  printf '    { user: "%s", password: $%s, permissions: {\n' "$p" "$(password_var "$p")"
  printf '        publish: { allow: [%s, "$JS.API.INFO"] }\n' "$pub"
  printf '        subscribe: { allow: [%s, "_INBOX.>"] } } }\n' "$sub"
done
echo "  ]"
echo "}"
