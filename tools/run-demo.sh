#!/bin/sh
# SPDX-License-Identifier: MIT
# make run: the daemon on its embedded demo (a replayed CMU clip, no
# hardware), with the avatar drawn in this terminal and in the browser
# viewer (its URL is printed). Ctrl-C stops both.
# Without a terminal (CI, a pipe) the avatar is shown as JSON statistics.
set -u
BUILD=${1:-build}
"$BUILD/avatargw" --demo &
daemon=$!
trap 'kill $daemon 2>/dev/null; wait $daemon 2>/dev/null; exit 0' INT TERM
sleep 0.5
if ! kill -0 $daemon 2>/dev/null; then
	wait $daemon
	exit $?
fi
cat <<EOM
avatargw is running the demo: UDP frames on 127.0.0.1:7770, a TCP stream on 127.0.0.1:7771.
  the viewer:     http://127.0.0.1:7780/   (open it in a browser on this host)
  watch frames:   $BUILD/avatargw-dump --udp 127.0.0.1:7770
  daemon status:  $BUILD/avatargw-ctl status
EOM
if [ -t 1 ]; then
	"$BUILD/avatargw-view" --tcp 127.0.0.1:7771
else
	"$BUILD/avatargw-dump" --tcp 127.0.0.1:7771 --stats
fi
kill $daemon 2>/dev/null
wait $daemon 2>/dev/null
