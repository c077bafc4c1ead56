#!/bin/sh
# SPDX-License-Identifier: MIT
# Writes the key reference of avatargw.conf(5) as roff, from two sources:
#
#   `avatargw --keys` (the built daemon): name, default, unit, the source
#   or output types that take the key, the meaning, then the kind of value,
#   the range and the allowed words. The keys live in typed tables: config.c's
#   for every section, each driver's and output's own for its type.
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
page=$root/docs/man/avatargw.conf.5

if [ ! -x "$bin" ]; then
	echo "man-keys.sh: $bin: no such program (build the daemon first, e.g. make)" >&2
	exit 2
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$bin" --keys >"$tmp/keys.tsv"

# the table's kind, range and words: the columns after the meaning (section, name, kind, lo, hi, words)
awk -F '\t' '
BEGIN {
	k["int"] = "K_INT"; k["u32"] = "K_U32"; k["number"] = "K_DOUBLE"; k["degrees"] = "K_DEG"; k["bool"] = "K_BOOL"
	k["enum"] = "K_ENUM"; k["string"] = "K_STR"; k["path"] = "K_PATH"; k["vec3"] = "K_VEC3"; k["range"] = "K_RANGE"
	k["sensor"] = "K_SENSOR"; k["person"] = "K_PERSON"; k["avatars"] = "K_LIST"; k["mount"] = "K_MOUNT"
	k["names"] = "K_NAMES"; k["axes"] = "K_AXES"; k["per-key"] = "K_PER"
}
/^\[/ { S = $0; gsub(/[][]/, "", S); split(S, w, " "); S = toupper(w[1]); next }
NF >= 9 { printf "%s\t%s\t%s\t%s\t%s\t%s\n", S, $1, k[$6], $7, $8, $9 }
' "$tmp/keys.tsv" >"$tmp/table.tsv"

if [ ! -s "$tmp/table.tsv" ]; then
	echo "man-keys.sh: $bin --keys printed no kinds (an older daemon? rebuild it)" >&2
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
	if (k == "K_AXES") return "z-up, y-up, three signed axes (x z -y) or qw qx qy qz"
	if (k == "K_PER") return "one key per channel (NAME.N)"
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
