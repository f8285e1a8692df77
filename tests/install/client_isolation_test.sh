#!/usr/bin/env bash
# libmimic_client.so is a client of Mimic's protocol over TCP and UDP, nothing more: it must not
# need libnats (a broker's scene is joined through a relay, above the client) nor carry the
# scene server. Reads the built library's dynamic section and symbol tables.
#   client_isolation_test.sh path/to/libmimic_client.so
set -euo pipefail
lib=$1
fail() { echo "FAIL: $*" >&2; exit 1; }
[ -f "$lib" ] || fail "no library at $lib"

needed=$(readelf -d "$lib" | grep NEEDED || true)
echo "$needed"
if grep -qi 'nats' <<<"$needed"; then fail "libmimic_client.so needs libnats"; fi

# Every symbol, hidden ones included (the static modules are linked in with hidden visibility,
# so only the full table shows what was pulled in). A stripped library would pass vacuously:
# the client's own code must be visible first.
symbols=$(nm -C "$lib")
grep -q 'mimic::net::Client::connect' <<<"$symbols" || fail "no symbol table to check (stripped?)"
for forbidden in 'mimic::net::Server::' 'mimic::net::ServerImpl' 'mimic::net::Session::' \
                 'mimic::net::NatsSceneFeed' 'mimic::net::NatsPublisher' 'EmbeddedRelay' 'natsConnection_'; do
  if hits=$(grep -F -- "$forbidden" <<<"$symbols"); then
    fail "libmimic_client.so carries '$forbidden':"$'\n'"$(head -5 <<<"$hits")"
  fi
done
# What it exports is the C and C++ client API alone.
if nm -D -C --defined-only "$lib" | grep -F 'mimic::net::'; then fail "libmimic_client.so exports mimic::net symbols"; fi
echo "ok: $(basename "$lib") needs no libnats and carries no server"
