#!/bin/sh
# SPDX-License-Identifier: MIT
# check-config-doc.sh [BUILD] [CONF] - checks that the reference configuration
# (CONF, default config/avatargw.conf) documents every key the daemon knows.
# Run it from the repository root; BUILD is the build directory (default
# build), whose avatargw prints the key table with --keys.
#
#  1. every key of `avatargw --keys` appears under a section of its kind in
#     CONF, either set ("key = value") or commented ("; key = value"); a
#     section counts whether it is real ("[source sim]") or commented
#     ("; [source clip]");
#  2. every "key =" line of CONF (set or commented) names a key of its section,
#     so that a misspelt example cannot hide;
#  3. `avatargw -c CONF --check-config` accepts CONF as it is;
#  4. with its commented sections and keys uncommented, CONF is still a valid
#     configuration (the examples work as written).
#
# Prints what is wrong and exits 1, or prints one OK line and exits 0.
set -u

build=${1:-${BUILD:-build}}
conf=${2:-config/avatargw.conf}
bin=$build/avatargw
me=check-config-doc

if [ ! -x "$bin" ]; then
	echo "$me: $bin not found: build it first (make $bin)"
	exit 1
fi
if [ ! -r "$conf" ]; then
	echo "$me: $conf not found (run from the repository root)"
	exit 1
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM
status=0

if ! "$bin" --keys >"$tmp/keys"; then
	echo "$me: $bin --keys failed"
	exit 1
fi

# "KIND KEY" for every key of the table: a line "[daemon]" or "[source NAME]"
# starts a section, then one tab-separated line per key, its name first.
awk -F '\t' '
	/^\[/ { kind = $0; sub(/^\[/, "", kind); sub(/[] ].*$/, "", kind); next }
	NF >= 5 && kind != "" { print kind " " $1 }
' "$tmp/keys" | sort -u >"$tmp/known"
if [ ! -s "$tmp/known" ]; then
	echo "$me: $bin --keys printed no keys"
	exit 1
fi

# "KIND KEY LINE" for every key line of CONF. A section line is "[KIND ...]"
# or "; [KIND ...]"; a key line is "key = ..." or "; key = ..." (one space at
# most after the ';': indented examples inside longer comments do not count).
awk '
	/^(; ?)?\[[a-z]+( [^]]*)?\][ \t]*$/ {
		kind = $0; sub(/^(; ?)?\[/, "", kind); sub(/[] ].*$/, "", kind); next
	}
	/^(; ?)?[a-z][a-z0-9_.]*[ \t]*=/ {
		key = $0; sub(/^(; ?)?/, "", key); sub(/[ \t]*=.*$/, "", key)
		# one key per sensor: mount_head, mount_p0.head ... are the key mount_SENSOR
		if (key ~ /^mount[_.]./) key = "mount_SENSOR"
		# one key per channel: sensor.0, buttons.1 ... are the keys sensor.N, buttons.N, analog.N
		if (key ~ /^(sensor|buttons|analog)\.[a-z0-9]+$/) { sub(/\..*$/, ".N", key) }
		print (kind == "" ? "(none)" : kind) " " key " " FNR
	}
' "$conf" >"$tmp/lines"
awk '{ print $1 " " $2 }' "$tmp/lines" | sort -u >"$tmp/documented"

missing=$(comm -23 "$tmp/known" "$tmp/documented")
if [ -n "$missing" ]; then
	echo "$me: $conf does not document these keys (add \"key = value\" or \"; key = default\" under the section):"
	echo "$missing" | sed 's/^\([^ ]*\) \(.*\)$/  [\1] \2/'
	status=1
fi

unknown=$(comm -13 "$tmp/known" "$tmp/documented")
if [ -n "$unknown" ]; then
	echo "$me: $conf has key lines that are no key of their section:"
	echo "$unknown" | while read -r kind key; do
		lines=$(awk -v k="$kind" -v n="$key" '$1 == k && $2 == n { printf "%s%s", sep, $3; sep = "," }' \
			"$tmp/lines")
		echo "  [$kind] $key (line $lines)"
	done
	status=1
fi

if ! "$bin" -c "$conf" --check-config >"$tmp/out" 2>"$tmp/err"; then
	echo "$me: $bin -c $conf --check-config rejects it:"
	sed 's/^/  /' "$tmp/err"
	status=1
fi

# the examples, uncommented: "; [kind name]" and "; key = value" lose their "; "
sed -E 's/^; (\[[a-z]+( [A-Za-z0-9_.-]+)?\]|[a-z][a-z0-9_]* =.*)$/\1/' "$conf" >"$tmp/examples.conf"
if ! "$bin" -c "$tmp/examples.conf" --check-config >"$tmp/out" 2>"$tmp/err"; then
	echo "$me: with its examples uncommented, $conf is not a valid configuration:"
	sed 's/^/  /' "$tmp/err"
	status=1
fi

if [ "$status" -eq 0 ]; then
	echo "$me: OK: $conf documents all $(wc -l <"$tmp/known") keys and passes --check-config, examples included"
fi
exit "$status"
