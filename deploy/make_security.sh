#!/usr/bin/env bash
# Creates the DDS Security files of a deployment (docs/security.md, "Files"):
#   - a project CA (EC P-256, self-signed) that is both the identity CA and the permissions CA,
#     unless --ca-dir names an existing one (ca_cert.pem + ca_key.pem);
#   - one identity per node: EC P-256 key + certificate signed by the CA, subject from the list;
#   - the governance document and one permissions document per identity, S/MIME-signed by the
#     CA (`openssl smime -sign -text`, what Cyclone DDS's access-control plugin verifies);
#   - per host, a copy of what that host needs: the CA certificate (never the CA key), the
#     signed governance, and the identities of the processes that host runs.
#
# Input is what `hexa_deploy generate` wrote into OUT/security-src/:
#   governance.xml, permissions/<identity>.xml and identities.txt, one line per identity:
#   "<identity> <host> <subject>" (subject as "CN=leg3,O=HexaTaar,OU=deployment-name").
# Output: OUT/ca/ (unless --ca-dir) and OUT/hosts/<host>/etc/hexa/security/.
#
# Usage: make_security.sh OUT [--ca-dir DIR] [--days N] [--start YYYYMMDDHHMMSSZ]
#                             [--end YYYYMMDDHHMMSSZ] [--only IDENTITY]
#   --days      validity of the identity certificates (default 3650)
#   --start/--end explicit validity window of the identity certificates (tests make expired ones)
#   --only      (re)make only this identity (e.g. to replace one board's certificate)
set -euo pipefail

usage() { sed -n '2,23p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "make_security: error: $*" >&2; exit 1; }

[ $# -ge 1 ] || { usage >&2; exit 2; }
case "$1" in -h|--help) usage; exit 0 ;; esac
out="$1"; shift
ca_dir=""; days=3650; start=""; end=""; only=""
while [ $# -gt 0 ]; do
  case "$1" in
    --ca-dir) ca_dir="${2:?--ca-dir needs a directory}"; shift 2 ;;
    --days) days="${2:?--days needs a number}"; shift 2 ;;
    --start) start="${2:?--start needs a date}"; shift 2 ;;
    --end) end="${2:?--end needs a date}"; shift 2 ;;
    --only) only="${2:?--only needs an identity}"; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done
command -v openssl >/dev/null || die "openssl not found (Debian package 'openssl')"
[[ "$days" =~ ^[0-9]+$ ]] && [ "$days" -ge 1 ] || die "--days '$days': expected a whole number >= 1"

src="$out/security-src"
[ -f "$src/identities.txt" ] || die "'$src/identities.txt' not found: run 'hexa_deploy generate' first"
[ -f "$src/governance.xml" ] || die "'$src/governance.xml' not found: run 'hexa_deploy generate' first"

# The CA. Its key signs every identity, the governance and the permissions; it belongs on the
# machine that makes the deployment, not on the boards.
if [ -z "$ca_dir" ]; then
  ca_dir="$out/ca"
  if [ ! -f "$ca_dir/ca_cert.pem" ]; then
    mkdir -p "$ca_dir"
    chmod 700 "$ca_dir"
    openssl ecparam -name prime256v1 -genkey -noout -out "$ca_dir/ca_key.pem" 2>/dev/null
    chmod 600 "$ca_dir/ca_key.pem"
    openssl req -new -x509 -key "$ca_dir/ca_key.pem" -out "$ca_dir/ca_cert.pem" -days 3650 \
      -sha256 -subj "/O=HexaTaar/CN=HexaTaar project CA" 2>/dev/null \
      || die "cannot create the CA certificate in '$ca_dir'"
    echo "make_security: created project CA $ca_dir/ca_cert.pem"
  fi
fi
[ -f "$ca_dir/ca_cert.pem" ] || die "CA certificate '$ca_dir/ca_cert.pem' not found"
[ -f "$ca_dir/ca_key.pem" ] || die "CA key '$ca_dir/ca_key.pem' not found"
ca_dir="$(cd "$ca_dir" && pwd)"

# `openssl ca` (not `x509 -req`) so that an explicit validity window can be given.
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
touch "$work/index.txt"
openssl rand -hex 16 > "$work/serial"
cat > "$work/ca.cnf" <<EOF
[ ca ]
default_ca = hexa_ca
[ hexa_ca ]
database = $work/index.txt
new_certs_dir = $work
serial = $work/serial
certificate = $ca_dir/ca_cert.pem
private_key = $ca_dir/ca_key.pem
default_md = sha256
policy = any
unique_subject = no
copy_extensions = none
email_in_dn = no
[ any ]
commonName = supplied
organizationName = optional
organizationalUnitName = optional
EOF

sign() {  # sign <in.xml> <out.p7s>
  openssl smime -sign -in "$1" -text -out "$2" -signer "$ca_dir/ca_cert.pem" \
    -inkey "$ca_dir/ca_key.pem" 2>/dev/null || die "cannot sign '$1'"
}

sec="$work/signed"
mkdir -p "$sec"
sign "$src/governance.xml" "$sec/governance.p7s"

made=0
while read -r id host subject; do
  [ -n "${id:-}" ] || continue
  case "$id" in \#*) continue ;; esac
  [ -z "$only" ] || [ "$only" = "$id" ] || continue
  [ -n "${subject:-}" ] || die "identities.txt: line for '$id' has no subject"
  [ -f "$src/permissions/$id.xml" ] || die "no permissions document '$src/permissions/$id.xml'"
  dest="$out/hosts/$host/etc/hexa/security"
  mkdir -p "$dest/$id"
  # "CN=leg3,O=HexaTaar,OU=x" -> "/CN=leg3/O=HexaTaar/OU=x"
  subj="/${subject//,//}"
  openssl ecparam -name prime256v1 -genkey -noout -out "$dest/$id/key.pem" 2>/dev/null
  chmod 640 "$dest/$id/key.pem"
  openssl req -new -key "$dest/$id/key.pem" -out "$work/$id.csr" -subj "$subj" 2>/dev/null \
    || die "cannot make a certificate request for '$id' (subject '$subject')"
  validity=(-days "$days")
  [ -z "$start" ] || validity=(-startdate "$start")
  [ -z "$end" ] || validity+=(-enddate "$end")
  if [ -n "$start" ] && [ -z "$end" ]; then die "--start needs --end"; fi
  openssl ca -batch -config "$work/ca.cnf" -in "$work/$id.csr" -out "$dest/$id/cert.pem" \
    -notext "${validity[@]}" >"$work/ca.log" 2>&1 \
    || die "cannot sign the certificate of '$id': $(tail -n 3 "$work/ca.log")"
  sign "$src/permissions/$id.xml" "$dest/$id/permissions.p7s"
  cp "$ca_dir/ca_cert.pem" "$dest/ca_cert.pem"
  cp "$sec/governance.p7s" "$dest/governance.p7s"
  made=$((made + 1))
done < "$src/identities.txt"

[ "$made" -gt 0 ] || die "no identity made${only:+ (no identity '$only' in identities.txt)}"
echo "make_security: $made identities signed by $ca_dir/ca_cert.pem into $out/hosts/*/etc/hexa/security"
