// SPDX-License-Identifier: MIT
/*
 * fuzz_dtrack.c - the ART DTrack source's frame decoder (dtrack_codec,
 * src/trackers/dtrack.c), fed datagrams as tests/fuzz/codec.h describes
 * (each "report" one datagram of ASCII lines). Variants: how many bodies
 * and Flysticks are taken.
 */
#include "fuzz/codec.h"

static const char *codec_config(unsigned v)
{
	static const char *const conf[4] = {
		"[source dt]\ntype = dtrack\n",
		"[source dt]\ntype = dtrack\nsensors = 1\nflysticks = 0\n",
		"[source dt]\ntype = dtrack\nsensors = 12\nflysticks = 4\n",
		"[source dt]\ntype = dtrack\nsensors = 3\nflysticks = 2\nsensor.f1 = stick\nsensor.0 = glasses\n",
	};

	return conf[v % 4];
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	return codec_run("dtrack", data, size);
}
