// SPDX-License-Identifier: MIT
/*
 * fuzz_vrpn_in.c - the VRPN client source's message decoder (vrpn_in_codec,
 * src/trackers/vrpn_in.c), fed messages as tests/fuzz/codec.h describes
 * (each "report" one VRPN message: header, payload, padding). Variants:
 * how many channels are taken, and which have buttons and analog values.
 */
#include "fuzz/codec.h"

static const char *codec_config(unsigned v)
{
	static const char *const conf[4] = {
		"[source cave]\ntype = vrpn\ndevice = Tracker0@localhost\n",
		"[source cave]\ntype = vrpn\ndevice = Tracker0@tcp://localhost:3884\nsensors = 1\n",
		"[source cave]\ntype = vrpn\ndevice = Tracker0@localhost\nsensors = 16\nbuttons.0 = 0 8\n"
		"analog.0 = 0 2\nbuttons.15 = 1000 32\nanalog.15 = 126 4\n",
		"[source cave]\ntype = vrpn\ndevice = Avatar0@localhost\nsensors = 13\nbuttons.11 = 32\n"
		"analog.11 = 21 4\n",
	};

	return conf[v % 4];
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	return codec_run("vrpn", data, size);
}
