#!/bin/sh
# SPDX-License-Identifier: MIT
# site-security.sh - the files of DDS Security for [site] security = DIR
# (docs/SITES.md), made with openssl:
#
#   tools/site-security.sh ca CA_DIR
#       a session's certificate authority: CA_DIR/ca.pem and CA_DIR/ca.key
#       (P-256, ten years), and the session's governance, signed:
#       CA_DIR/governance.p7s (authenticated participants only, every
#       avatargw topic encrypted, discovery and liveliness protected).
#
#   tools/site-security.sh site CA_DIR NAME DIR [--days N] [--expired]
#       site NAME's files in DIR: cert.pem and key.pem (signed by the CA,
#       subject CN=NAME,O=avatargw), permissions.p7s (NAME may publish and
#       subscribe every topic of every domain and session), and copies of
#       ca.pem and governance.p7s. --days: validity (default 365);
#       --expired: a certificate that expired yesterday (for tests).
#
# Keep ca.key away from the sites: whoever has it can make sites.
set -eu

me=site-security.sh
usage() {
	sed -n '3,20s/^# \{0,1\}//p' "$0"
	exit 2
}
[ $# -ge 2 ] || usage
command -v openssl >/dev/null || {
	echo "$me: openssl not found (Debian package openssl)" >&2
	exit 1
}

# the rules of the session: every participant authenticated, every topic encrypted
governance() {
	cat <<'EOF'
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>230</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
}

# what site $1 may do: publish and subscribe everything (the session's CA decides who is a site)
permissions() {
	cat <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="site_$1">
      <subject_name>CN=$1,O=avatargw</subject_name>
      <validity><not_before>$2</not_before><not_after>$3</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>230</max></id_range></domains>
        <publish><topics><topic>*</topic></topics><partitions><partition>*</partition></partitions></publish>
        <subscribe><topics><topic>*</topic></topics><partitions><partition>*</partition></partitions></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
}

sign() { # sign FILE.xml OUT.p7s CA_DIR
	openssl smime -sign -in "$1" -text -out "$2" -signer "$3/ca.pem" -inkey "$3/ca.key"
}

case $1 in
ca)
	dir=$2
	mkdir -p "$dir"
	openssl ecparam -name prime256v1 -genkey -noout -out "$dir/ca.key" 2>/dev/null
	chmod 600 "$dir/ca.key"
	openssl req -x509 -new -key "$dir/ca.key" -sha256 -days 3650 -subj "/O=avatargw/CN=avatargw session CA" \
		-out "$dir/ca.pem"
	governance >"$dir/governance.xml"
	sign "$dir/governance.xml" "$dir/governance.p7s" "$dir"
	echo "$me: session CA in $dir (ca.pem, ca.key, governance.p7s)"
	;;
site)
	[ $# -ge 4 ] || usage
	ca=$2
	name=$3
	dir=$4
	shift 4
	days=365
	expired=0
	while [ $# -gt 0 ]; do
		case $1 in
		--days) days=$2; shift 2 ;;
		--expired) expired=1; shift ;;
		*) usage ;;
		esac
	done
	case $name in
	*[!A-Za-z0-9_.-]* | "") echo "$me: '$name' is not a site name" >&2; exit 2 ;;
	esac
	[ -r "$ca/ca.pem" ] && [ -r "$ca/ca.key" ] || {
		echo "$me: $ca has no ca.pem and ca.key (make them with: $0 ca $ca)" >&2
		exit 1
	}
	mkdir -p "$dir"
	tmp=$(mktemp -d)
	trap 'rm -rf "$tmp"' EXIT
	openssl ecparam -name prime256v1 -genkey -noout -out "$dir/key.pem" 2>/dev/null
	chmod 600 "$dir/key.pem"
	openssl req -new -key "$dir/key.pem" -subj "/O=avatargw/CN=$name" -out "$tmp/req.csr"
	# openssl ca: the only way to give a certificate dates of our choosing
	mkdir -p "$tmp/db"
	: >"$tmp/db/index.txt"
	cat >"$tmp/ca.cnf" <<EOF
[ca]
default_ca = site
[site]
database = $tmp/db/index.txt
new_certs_dir = $tmp/db
rand_serial = yes
default_md = sha256
policy = any
copy_extensions = none
unique_subject = no
[any]
organizationName = supplied
commonName = supplied
EOF
	if [ "$expired" -eq 1 ]; then
		dates="-startdate $(date -u -d '-10 days' +%Y%m%d%H%M%SZ) -enddate $(date -u -d '-1 day' +%Y%m%d%H%M%SZ)"
	else
		dates="-startdate $(date -u -d '-1 hour' +%Y%m%d%H%M%SZ) -days $days"
	fi
	# shellcheck disable=SC2086
	openssl ca -batch -config "$tmp/ca.cnf" -cert "$ca/ca.pem" -keyfile "$ca/ca.key" $dates \
		-in "$tmp/req.csr" -out "$tmp/cert.pem" 2>"$tmp/ca.err" || {
		cat "$tmp/ca.err" >&2
		exit 1
	}
	openssl x509 -in "$tmp/cert.pem" -out "$dir/cert.pem"
	cp "$ca/ca.pem" "$ca/governance.p7s" "$dir/"
	permissions "$name" "$(date -u -d '-1 hour' +%Y-%m-%dT%H:%M:%S)" \
		"$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)" >"$tmp/permissions.xml"
	sign "$tmp/permissions.xml" "$dir/permissions.p7s" "$ca"
	echo "$me: site $name in $dir (cert.pem, key.pem, permissions.p7s, ca.pem, governance.p7s)"
	;;
*)
	usage
	;;
esac
