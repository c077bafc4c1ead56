// SPDX-License-Identifier: MIT
/*
 * fuzz_polhemus.c - the Polhemus record decoder (polhemus_codec,
 * src/trackers/polhemus.c): bulk transfers as tests/fuzz/codec.h describes,
 * for every model and a few station lists.
 */
#include "fuzz/codec.h"

static const char *codec_config(unsigned v)
{
	static const char *const c[8] = {
		"[source p]\ntype = polhemus\n",
		"[source p]\ntype = polhemus\nmodel = liberty\n",
		"[source p]\ntype = polhemus\nmodel = liberty_hs\nsensors = head left_hand right_hand\n",
		"[source p]\ntype = polhemus\nmodel = patriot\nsensors = a b\n",
		"[source p]\ntype = polhemus\nmodel = patriot_hs\n",
		"[source p]\ntype = polhemus\nsensors = a - c - e f g h i j k l m n o p\n",
		"[source p]\ntype = polhemus\nmodel = liberty\nsensors = - - head\n",
		"[source p]\ntype = polhemus\nmodel = liberty_hs\n",
	};

	return c[v % 8];
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	return codec_run("polhemus", data, size);
}
