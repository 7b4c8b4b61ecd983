#!/usr/bin/env bash
# Makes a lab's certificates for palp.v1 over TLS with the openssl command (docs/security.md):
#
#   deploy/make-certs.sh DIR ca                     the lab CA: DIR/ca.crt, DIR/ca.key (10 years)
#   deploy/make-certs.sh DIR server NAME [NAME...]  palpd's: DIR/server.crt, DIR/server.key for the
#                                                   host names / IP addresses stations connect to
#   deploy/make-certs.sh DIR client NAME            a station's (controllers): DIR/clients/NAME.crt
#                                                   and .key; NAME is the subject palpd logs
#   deploy/make-certs.sh DIR show                   what DIR holds: subjects, expiry, fingerprints
#
# EC P-256 keys, SHA-256 signatures; server and client certificates last PALP_CERT_DAYS days
# (default 398), the CA PALP_CA_DAYS (3650). Keys are written mode 600 and never overwritten
# (remove one to make it again: that is how a certificate is rotated). Keep DIR/ca.key off the
# palpd machine and the stations; copy only the files each one needs (docs/security.md).
set -euo pipefail
usage() { sed -n '2,15p' "$0"; }
[[ $# -ge 2 ]] || { usage >&2; exit 2; }
dir=$1 what=$2
shift 2
days=${PALP_CERT_DAYS:-398}
ca_days=${PALP_CA_DAYS:-3650}
org=${PALP_CERT_ORG:-palp lab}
command -v openssl >/dev/null || { echo "make-certs: needs the openssl command (apt-get install openssl)" >&2; exit 1; }
umask 077
mkdir -p "$dir"

refuse_existing() {
  local f
  for f in "$@"; do
    [[ ! -e $f ]] || { echo "make-certs: $f exists; remove it first to make a new one" >&2; exit 1; }
  done
}
need_ca() {
  [[ -f $dir/ca.crt && -f $dir/ca.key ]] || { echo "make-certs: no CA in $dir: run '$0 $dir ca' first" >&2; exit 1; }
}
# signed NAME_BASE CN EXTENSIONS: a key and a certificate signed by the CA.
signed() {
  local base=$1 cn=$2 ext=$3
  refuse_existing "$base.key" "$base.crt"
  openssl req -new -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout "$base.key" \
    -out "$base.csr" -subj "/O=$org/CN=$cn" 2>/dev/null
  printf '%s\n' "$ext" >"$base.ext"
  openssl x509 -req -in "$base.csr" -CA "$dir/ca.crt" -CAkey "$dir/ca.key" -CAcreateserial \
    -days "$days" -sha256 -extfile "$base.ext" -out "$base.crt" 2>/dev/null
  rm -f "$base.csr" "$base.ext"
  chmod 600 "$base.key"
  chmod 644 "$base.crt"
  echo "make-certs: $base.crt ($cn, $days days), key $base.key (mode 600)"
}

case $what in
  ca)
    refuse_existing "$dir/ca.key" "$dir/ca.crt"
    openssl req -x509 -new -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \
      -keyout "$dir/ca.key" -out "$dir/ca.crt" -days "$ca_days" -sha256 \
      -subj "/O=$org/CN=$org CA" -addext "basicConstraints=critical,CA:TRUE" \
      -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null
    chmod 644 "$dir/ca.crt"
    echo "make-certs: $dir/ca.crt (the CA stations and palpd trust), $dir/ca.key (keep it offline)"
    ;;
  server)
    [[ $# -ge 1 ]] || { echo "make-certs: server needs the host names or addresses stations use" >&2; exit 2; }
    need_ca
    san=""
    for name in "$@"; do
      if [[ $name =~ ^[0-9.]+$ || $name == *:* ]]; then san+="${san:+,}IP:$name"; else san+="${san:+,}DNS:$name"; fi
    done
    signed "$dir/server" "$1" "basicConstraints=CA:FALSE
keyUsage=critical,digitalSignature
extendedKeyUsage=serverAuth
subjectAltName=$san"
    echo "make-certs: pin for --tls-pin: $(openssl x509 -noout -fingerprint -sha256 -in "$dir/server.crt" | cut -d= -f2)"
    ;;
  client)
    [[ $# -eq 1 && $1 =~ ^[A-Za-z0-9._-]+$ ]] || { echo "make-certs: client needs one NAME (letters, digits, . _ -)" >&2; exit 2; }
    need_ca
    mkdir -p "$dir/clients"
    signed "$dir/clients/$1" "$1" "basicConstraints=CA:FALSE
keyUsage=critical,digitalSignature
extendedKeyUsage=clientAuth"
    ;;
  show)
    for crt in "$dir"/ca.crt "$dir"/server.crt "$dir"/clients/*.crt; do
      [[ -f $crt ]] || continue
      echo "$crt"
      openssl x509 -noout -subject -enddate -fingerprint -sha256 -in "$crt" | sed 's/^/  /'
    done
    ;;
  -h | --help) usage ;;
  *) usage >&2; exit 2 ;;
esac
