#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs the Debian 12 packages avatargw needs to build, test and benchmark.
# Idempotent: packages already present are left alone. Run as root (or with sudo).
set -eu

PKGS="
build-essential
g++
make
pkg-config
clang-format
libcmocka-dev
libglm-dev
libinih-dev
python3
systemd
man-db
groff-base
libhidapi-dev
libusb-1.0-0-dev
libmodbus-dev
python3-pymodbus
python3-serial-asyncio
libwebsockets-dev
liblo-dev
liblo-tools
libjs-three
chromium
python3-matplotlib
python3-numpy
gcc-arm-none-eabi
libnewlib-arm-none-eabi
gcc-aarch64-linux-gnu
libc6-dev-arm64-cross
qemu-user
qemu-system-arm
can-utils
iproute2
zlib1g-dev
valgrind
cyclonedds-dev
libddsc0debian
cyclonedds-tools
libfastrtps-dev
libfastcdr-dev
fastddsgen
default-jre-headless
openssl
clang-14
libclang-rt-14-dev
libfuzzer-14-dev
"

missing=""
for p in $PKGS; do
	if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
		missing="$missing $p"
	fi
done
if [ -z "$missing" ]; then
	echo "install-deps: all packages present"
	exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO=sudo
echo "install-deps: installing:$missing"
$SUDO apt-get update -qq
# shellcheck disable=SC2086
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing
