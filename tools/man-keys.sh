#!/bin/sh
# SPDX-License-Identifier: MIT
# Writes the key reference of avatargw.conf(5) as roff, from two sources:
#
#   - `avatargw --keys` (the built daemon): name, default, unit, the source
#     or output types that take the key, and the meaning;
#   - the keys[] table of src/config/config.c: the kind of value, the range
#     and the allowed words, which --keys does not print.
#
# Both describe the same table, so a key present in one and not the other
# means the binary is older than the source: rebuild it.
#
# usage: tools/man-keys.sh [-b BINARY] [--update]
#   -b BINARY  the daemon to ask (default: $BUILD/avatargw, BUILD defaulting to build)
#   --update   replace the generated part of docs/man/avatargw.conf.5 in place
#              (between the BEGIN KEYS and END KEYS comment lines);
#              without it the part goes to standard output.
#
# A developer tool: `make install` does not run it, the page is committed.
# tools/check-man.sh compares the committed page with a fresh run.
set -eu

root=$(cd "$(dirname "$0")/.." && pwd)
case ${BUILD:-build} in
/*) bin=${BUILD}/avatargw ;;
*) bin=$root/${BUILD:-build}/avatargw ;;
esac
update=0
while [ $# -gt 0 ]; do
	case $1 in
	-b) bin=$2; shift 2 ;;
	--update) update=1; shift ;;
	-h | --help) sed -n '2,20s/^# \{0,1\}//p' "$0"; exit 0 ;;
	*) echo "man-keys.sh: unknown argument $1" >&2; exit 2 ;;
	esac
done
src=$root/src/config/config.c
hdr=$root/src/config/config.h
page=$root/docs/man/avatargw.conf.5

if [ ! -x "$bin" ]; then
	echo "man-keys.sh: $bin: no such program (build the daemon first, e.g. make)" >&2
	exit 2
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$bin" --keys >"$tmp/keys.tsv"

# The table in the source: one line per key, "SECT<TAB>name<TAB>KIND<TAB>min<TAB>max<TAB>words",
# where words are the allowed values of an enumerated key.
awk -v hdr="$hdr" '
function trim(s) { sub(/^[ \t]+/, "", s); sub(/[ \t]+$/, "", s); return s }
function num(s,   v) {
	s = trim(s)
	if (s in defs) s = defs[s]
	if (s !~ /^-?[0-9.]+([eE][-+]?[0-9]+)?$/) return s
	return sprintf("%.10g", s + 0)
}
BEGIN {
	while ((getline l < hdr) > 0)
		if (l ~ /^#define [A-Z_]+ +-?[0-9]/) { split(l, f, /[ \t]+/); defs[f[2]] = f[3] }
}
/^static const char \*const e_[a-z_]+\[\] = \{/ {
	name = $0; sub(/^static const char \*const /, "", name); sub(/\[.*/, "", name)
	body = $0
	while (body !~ /NULL/ && (getline l) > 0) body = body " " l
	sub(/^[^{]*\{/, "", body); sub(/NULL.*/, "", body)
	gsub(/[" \t]/, "", body); sub(/,$/, "", body); gsub(/,/, " ", body)
	words[name] = body
	next
}
/^static const struct key_def keys\[\] = \{/ { intable = 1; next }
intable && /^\};/ { intable = 0; flush(); next }
intable {
	if ($0 ~ /^[ \t]*\{ S_[A-Z]+,/) { flush(); entry = $0 } else entry = entry " " $0
	next
}
function flush(   f, n, e) {
	if (entry == "") return
	n = split(entry, f, ",")
	e = ""
	if (match(entry, /, e_[a-z_]+,/)) e = substr(entry, RSTART + 2, RLENGTH - 3)
	f[1] = trim(f[1]); sub(/^\{ S_/, "", f[1])
	f[2] = trim(f[2]); gsub(/"/, "", f[2])
	printf "%s\t%s\t%s\t%s\t%s\t%s\n", f[1], f[2], trim(f[3]), num(f[6]), num(f[7]), (e in words) ? words[e] : ""
	entry = ""
}
' "$src" >"$tmp/table.tsv"

if [ ! -s "$tmp/table.tsv" ]; then
	echo "man-keys.sh: found no keys[] table in $src" >&2
	exit 2
fi

# roff from both; fails naming any key that only one of them knows
awk -F '\t' -v table="$tmp/table.tsv" '
# roff text: backslashes, minus signs (a "-" that starts a word), leading dots
function esc(s,   out, i, c, prev) {
	gsub(/\\/, "\\e", s)
	out = ""; prev = " "
	for (i = 1; i <= length(s); i++) {
		c = substr(s, i, 1)
		if (c == "-" && (prev == " " || prev == "(" || prev == "[")) out = out "\\-"
		else out = out c
		prev = c
	}
	if (out ~ /^[.\047]/) out = "\\&" out
	return out
}
function kind_text(k, w) {
	if (k == "K_INT" || k == "K_U32") return "integer"
	if (k == "K_DOUBLE" || k == "K_DEG") return "number"
	if (k == "K_BOOL") return "boolean (yes or no)"
	if (k == "K_ENUM") { gsub(/ /, ", ", w); return "one of " w }
	if (k == "K_STR") return "string"
	if (k == "K_PATH") return "path"
	if (k == "K_VEC3") return "three numbers, x y z"
	if (k == "K_RANGE") return "two numbers, lo hi, lo <= hi"
	if (k == "K_SENSOR") return "SOURCE/SENSOR"
	if (k == "K_PERSON") return "SOURCE or SOURCE/PREFIX"
	if (k == "K_LIST") return "list of avatar names, or all"
	if (k == "K_MOUNT") return "x y z, optionally followed by qw qx qy qz"
	if (k == "K_NAMES") return "sensor names separated by spaces, - for none"
	return ""
}
BEGIN {
	while ((getline l < table) > 0) {
		split(l, f, "\t")
		# a key may have several entries (one per set of types): number them in table order
		id = f[1] "." f[2]; n_occ[id]++; id = id "#" n_occ[id]
		kind[id] = f[3]; lo[id] = f[4]; hi[id] = f[5]; words[id] = f[6]
		order[++n_table] = id
	}
	bad = 0
}
/^\[/ {
	sect = $0; gsub(/[][]/, "", sect); split(sect, sw, " "); S = toupper(sw[1])
	printf ".SS \"[%s]\"\n", sect
	next
}
{
	id = S "." $1; seen_occ[id]++; id = id "#" seen_occ[id]
	if (!(id in kind)) { printf "man-keys.sh: [%s] %s: not in the keys[] table of config.c (rebuild the daemon)\n", sect, $1 > "/dev/stderr"; bad = 1; next }
	seen[id] = 1
	k = kind[id]
	t = kind_text(k, words[id])
	if (t == "") { printf "man-keys.sh: %s: kind %s unknown to this script\n", id, k > "/dev/stderr"; bad = 1; next }
	printf ".TP\n.B %s\n%s\n.br\n", $1, esc($5)
	line = "Value: " t
	if ($3 != "-") line = line "; unit: " $3
	if ((k == "K_INT" || k == "K_U32" || k == "K_DOUBLE" || k == "K_DEG") && !(lo[id] == "0" && hi[id] == "0"))
		line = line "; from " lo[id] " to " hi[id]
	else if ((k == "K_VEC3" || k == "K_RANGE") && !(lo[id] == "0" && hi[id] == "0"))
		line = line "; each from " lo[id] " to " hi[id]
	printf "%s.\n", esc(line)
	if ($2 == "(required)") line = "Required."
	else if ($2 == "") line = "Default: empty."
	else line = "Default: " $2 "."
	printf "%s\n", esc(line)
	if ($4 != "all") {
		n_only = split($4, o, " ")
		line = "Only for " (S == "SOURCE" ? "sources" : "outputs") " of type "
		for (i = 1; i <= n_only; i++) line = line (i > 1 ? (i == n_only ? " or " : ", ") : "") o[i]
		printf "%s.\n", esc(line)
	}
}
END {
	for (i = 1; i <= n_table; i++)
		if (!(order[i] in seen)) { printf "man-keys.sh: %s: in config.c but not printed by --keys (rebuild the daemon)\n", order[i] > "/dev/stderr"; bad = 1 }
	exit bad
}
' "$tmp/keys.tsv" >"$tmp/keys.roff"

if [ "$update" -eq 0 ]; then
	cat "$tmp/keys.roff"
	exit 0
fi

# the lines between the comment lines .\" BEGIN KEYS ... and .\" END KEYS
awk -v gen="$tmp/keys.roff" '
	/^\.\\" BEGIN KEYS/ { print; while ((getline l < gen) > 0) print l; skip = 1; found++; next }
	/^\.\\" END KEYS/ { skip = 0; found++ }
	!skip { print }
	END { exit found == 2 ? 0 : 1 }
' "$page" >"$tmp/page" || {
	echo "man-keys.sh: $page needs one BEGIN KEYS and one END KEYS comment line" >&2
	exit 2
}
cat "$tmp/page" >"$page"
echo "man-keys.sh: updated $page"
