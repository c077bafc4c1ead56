// SPDX-License-Identifier: MIT
/*
 * fuzz_hydra.c - the Razer Hydra's report decoder (hydra_codec,
 * src/trackers/hydra.c), fed reports as tests/fuzz/codec.h describes.
 */
#include "fuzz/codec.h"

static const char *codec_config(unsigned v)
{
	(void)v;
	return "[source hydra]\ntype = hydra\n";
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	return codec_run("hydra", data, size);
}
